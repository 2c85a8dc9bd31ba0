//! The inputs of a drawdown fit as a front end collects them, each optional
//! (`km fit --km`'s flags, `km.fit_km`'s keywords): which [`Readings`] they
//! make, which input is missing or does not belong, and Saunderson's
//! correction from `n` and `k2`. Decided once here; each front end words an
//! [`InputError`] in its own names ([`InputError::message`]).
//!
//! The rules (`docs/inverse-km.md`):
//! * `r_black` and `r_white` (the film over two grounds) need `r_white_ground`
//!   and `thickness`; `r_black_ground` defaults to 0 (ideal black);
//! * otherwise `r_inf` with `r_zero` and `thickness`, or `r_inf` alone (only
//!   `K/S`; a thickness is then refused: it would be ignored);
//! * the two kinds of readings exclude each other;
//! * `n` asks for Saunderson's correction (the readings are instrument
//!   readings, specular component included), `k2` defaults to the
//!   hemispherical Fresnel reflectance from inside; `k2` without `n` is refused.

use thiserror::Error;

use super::{DrawdownFit, Readings, fit_drawdown};
use crate::kubelka::{KubelkaError, Saunderson, Specular};

/// One input of a drawdown fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Input {
    /// Reflectance of the film over the dark ground.
    RBlack,
    /// Reflectance of the film over the light ground.
    RWhite,
    /// Reflectance of the light ground itself.
    RWhiteGround,
    /// Reflectance of the dark ground itself.
    RBlackGround,
    /// Reflectance of the opaque film.
    RInf,
    /// Reflectance of the film over ideal black.
    RZero,
    /// Film thickness.
    Thickness,
    /// Refractive index of the binder (Saunderson's `k1`).
    N,
    /// Saunderson's internal diffuse reflectance `k2`.
    K2,
}

impl Input {
    /// Every input.
    pub const ALL: [Input; 9] = [
        Input::RBlack,
        Input::RWhite,
        Input::RWhiteGround,
        Input::RBlackGround,
        Input::RInf,
        Input::RZero,
        Input::Thickness,
        Input::N,
        Input::K2,
    ];

    /// The library's name of the input (`r_black`, ..., `n`, `k2`): the
    /// names of [`Readings::inputs`] and of [`KubelkaError`]'s messages.
    pub fn name(self) -> &'static str {
        match self {
            Input::RBlack => "r_black",
            Input::RWhite => "r_white",
            Input::RWhiteGround => "r_white_ground",
            Input::RBlackGround => "r_black_ground",
            Input::RInf => "r_inf",
            Input::RZero => "r_zero",
            Input::Thickness => "thickness",
            Input::N => "n",
            Input::K2 => "k2",
        }
    }

    /// What the input is, or why it is needed, in a message's parentheses.
    fn what(self) -> &'static str {
        match self {
            Input::RBlack => "the film over the dark ground",
            Input::RWhite => "the film over the light ground",
            Input::RWhiteGround => "the reflectance of the light ground",
            Input::RBlackGround => "the reflectance of the dark ground",
            Input::RInf => "the reflectance of the opaque film",
            Input::RZero => "the film over ideal black",
            Input::Thickness => "the film thickness",
            Input::N => "k1 is the Fresnel reflectance of the binder",
            Input::K2 => "Saunderson's internal reflectance",
        }
    }

    /// The input a library refusal names (`KubelkaError::Invalid` or
    /// `Infeasible` with one of the names of [`Input::name`]), if any.
    pub fn named_by(e: &KubelkaError) -> Option<Input> {
        let name = match e {
            KubelkaError::Invalid { name, .. } | KubelkaError::Infeasible { name, .. } => name,
            KubelkaError::Core(_) => return None,
        };
        Input::ALL.into_iter().find(|i| i.name() == name)
    }
}

/// The inputs of a drawdown fit, each optional (which are required depends
/// on which readings are given: see the module documentation).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct DrawdownInputs {
    /// Reflectance of the film over the dark ground.
    #[cfg_attr(
        feature = "clap",
        arg(long = "r-black", help = "--km: reflectance of the film over the black ground")
    )]
    pub r_black: Option<f64>,
    /// Reflectance of the film over the light ground.
    #[cfg_attr(
        feature = "clap",
        arg(long = "r-white", help = "--km: reflectance of the film over the white ground")
    )]
    pub r_white: Option<f64>,
    /// Reflectance of the light ground itself.
    #[cfg_attr(
        feature = "clap",
        arg(long = "r-white-ground", help = "--km: reflectance of the white ground itself")
    )]
    pub r_white_ground: Option<f64>,
    /// Reflectance of the dark ground itself (default 0: ideal black).
    #[cfg_attr(
        feature = "clap",
        arg(
            long = "r-black-ground",
            help = "--km: reflectance of the black ground itself (default 0: ideal black)"
        )
    )]
    pub r_black_ground: Option<f64>,
    /// Reflectance of the opaque film.
    #[cfg_attr(
        feature = "clap",
        arg(long = "r-inf", help = "--km: reflectance of an opaque (infinitely thick) film")
    )]
    pub r_inf: Option<f64>,
    /// Reflectance of the film over an ideal black ground.
    #[cfg_attr(
        feature = "clap",
        arg(long = "r-zero", help = "--km: reflectance of the film over a black ground (R_0)")
    )]
    pub r_zero: Option<f64>,
    /// Film thickness (any unit; `K`, `S` come out in its inverse).
    #[cfg_attr(feature = "clap", arg(skip))]
    pub thickness: Option<f64>,
    /// Refractive index of the binder: the readings are instrument readings
    /// and get Saunderson's correction.
    #[cfg_attr(feature = "clap", arg(skip))]
    pub n: Option<f64>,
    /// Saunderson's `k2` (needs `n`; default: the hemispherical Fresnel
    /// reflectance from inside).
    #[cfg_attr(
        feature = "clap",
        arg(long, help = "--km: Saunderson k2 (internal diffuse reflectance of the surface)")
    )]
    pub k2: Option<f64>,
}

/// Why the inputs make no fit. [`InputError::message`] words it with the
/// caller's names of the inputs; `Display` uses the library's ([`Input::name`]).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum InputError {
    /// Readings over two grounds and readings of the opaque film, together.
    #[error("{}", self.message(|i| i.name().to_string()))]
    BothKinds,
    /// `needed` is missing; `by` is the input that calls for it, if one does.
    #[error("{}", self.message(|i| i.name().to_string()))]
    Missing {
        /// The missing input.
        needed: Input,
        /// The input given that needs it.
        by: Option<Input>,
    },
    /// A ground's reflectance (`ground`) without the film's readings over the grounds.
    #[error("{}", self.message(|i| i.name().to_string()))]
    GroundWithoutFilm {
        /// The ground given.
        ground: Input,
    },
    /// A thickness with `r_inf` alone, which gives only `K/S`.
    #[error("{}", self.message(|i| i.name().to_string()))]
    ThicknessWithoutRZero,
    /// No readings at all.
    #[error("{}", self.message(|i| i.name().to_string()))]
    NoReadings,
    /// A value the library refused (Saunderson's `n` or `k2`, readings no
    /// film can produce, values out of range): `input` is the input the
    /// refusal names, if it names one.
    #[error("{source}")]
    Refused {
        /// The input refused.
        input: Option<Input>,
        /// The library's refusal (naming the value by [`Input::name`]).
        source: KubelkaError,
    },
}

impl InputError {
    /// The input the error is about (for a front end's error key): the
    /// missing or misplaced input; `r_inf` for both kinds of readings or none.
    pub fn input(&self) -> Option<Input> {
        match self {
            InputError::BothKinds | InputError::NoReadings => Some(Input::RInf),
            InputError::Missing { needed, .. } => Some(*needed),
            InputError::GroundWithoutFilm { ground } => Some(*ground),
            InputError::ThicknessWithoutRZero => Some(Input::Thickness),
            InputError::Refused { input, .. } => *input,
        }
    }

    /// The message, each input spelled by `name` (`--r-black` on the command
    /// line, `r_black` in Python). A [`InputError::Refused`] gives the
    /// library's refusal as it is (it names the value by [`Input::name`]).
    pub fn message(&self, name: impl Fn(Input) -> String) -> String {
        use Input::*;
        match self {
            InputError::BothKinds => format!(
                "give either {}/{} (film over two grounds) or {} [{}], not both",
                name(RBlack),
                name(RWhite),
                name(RInf),
                name(RZero)
            ),
            InputError::Missing { needed, by: Some(by) } => {
                format!("{} needs {} ({})", name(*by), name(*needed), needed.what())
            }
            InputError::Missing { needed, by: None } => {
                format!("{} ({}) is required", name(*needed), needed.what())
            }
            InputError::GroundWithoutFilm { .. } => format!(
                "{}/{} belong to {}/{}",
                name(RWhiteGround),
                name(RBlackGround),
                name(RBlack),
                name(RWhite)
            ),
            InputError::ThicknessWithoutRZero => format!(
                "{} needs {}: an opaque film alone gives only K/S",
                name(Thickness),
                name(RZero)
            ),
            InputError::NoReadings => format!(
                "no readings: give {}, {}, {} and {}, or {} [{} {}]",
                name(RBlack),
                name(RWhite),
                name(RWhiteGround),
                name(Thickness),
                name(RInf),
                name(RZero),
                name(Thickness)
            ),
            InputError::Refused { source, .. } => source.to_string(),
        }
    }
}

impl DrawdownInputs {
    /// Which readings the inputs give, each missing or misplaced input named.
    ///
    /// # Errors
    /// [`InputError`] other than `Refused` (see the module documentation).
    ///
    /// ```
    /// use km_inverse::drawdown::{DrawdownInputs, Input, InputError, Readings};
    /// let i = DrawdownInputs { r_inf: Some(0.6), ..Default::default() };
    /// assert_eq!(i.readings(), Ok(Readings::RInf { r_inf: 0.6 }));
    /// let i = DrawdownInputs { r_zero: Some(0.3), ..Default::default() };
    /// let e = i.readings().unwrap_err();
    /// assert_eq!(e, InputError::Missing { needed: Input::RInf, by: Some(Input::RZero) });
    /// assert_eq!(e.message(|i| format!("--{}", i.name().replace('_', "-"))),
    ///            "--r-zero needs --r-inf (the reflectance of the opaque film)");
    /// ```
    pub fn readings(&self) -> Result<Readings, InputError> {
        let need = |v: Option<f64>, needed: Input, by: Option<Input>| {
            v.ok_or(InputError::Missing { needed, by })
        };
        let two_grounds = self.r_black.is_some() || self.r_white.is_some();
        if two_grounds && (self.r_inf.is_some() || self.r_zero.is_some()) {
            return Err(InputError::BothKinds);
        }
        if two_grounds {
            // Each film reading calls for the other, then the ground and the thickness.
            let r_black = need(self.r_black, Input::RBlack, Some(Input::RWhite))?;
            let r_white = need(self.r_white, Input::RWhite, Some(Input::RBlack))?;
            let g_white = need(self.r_white_ground, Input::RWhiteGround, None)?;
            let thickness = need(self.thickness, Input::Thickness, None)?;
            let g_black = self.r_black_ground.unwrap_or(0.0);
            return Ok(Readings::BlackWhite { r_black, g_black, r_white, g_white, thickness });
        }
        if let Some(ground) =
            [(self.r_white_ground, Input::RWhiteGround), (self.r_black_ground, Input::RBlackGround)]
                .into_iter()
                .find_map(|(v, i)| v.map(|_| i))
        {
            return Err(InputError::GroundWithoutFilm { ground });
        }
        match (self.r_inf, self.r_zero) {
            (Some(r_inf), Some(r_zero)) => {
                let thickness = need(self.thickness, Input::Thickness, None)?;
                Ok(Readings::RInfRZero { r_inf, r_zero, thickness })
            }
            (None, Some(_)) => {
                Err(InputError::Missing { needed: Input::RInf, by: Some(Input::RZero) })
            }
            (Some(_), None) if self.thickness.is_some() => Err(InputError::ThicknessWithoutRZero),
            (Some(r_inf), None) => Ok(Readings::RInf { r_inf }),
            (None, None) => Err(InputError::NoReadings),
        }
    }

    /// Saunderson's correction asked for by `n` (and `k2`), if any:
    /// [`Saunderson::fresnel`] from `n` alone, [`Saunderson::from_index`]
    /// with `k2`; the specular component is included in the readings.
    ///
    /// # Reference
    /// Saunderson 1942 (eq. I8–I9 of `docs/inverse-km.md`).
    ///
    /// # Errors
    /// `k2` without `n` ([`InputError::Missing`]); `n` or `k2` out of range
    /// ([`InputError::Refused`]).
    pub fn saunderson(&self) -> Result<Option<Saunderson>, InputError> {
        let refused = |source: KubelkaError, default: Input| InputError::Refused {
            input: Input::named_by(&source).or(Some(default)),
            source,
        };
        match (self.n, self.k2) {
            (None, None) => Ok(None),
            (None, Some(_)) => Err(InputError::Missing { needed: Input::N, by: Some(Input::K2) }),
            (Some(n), None) => Saunderson::fresnel(n, Specular::Included)
                .map(Some)
                .map_err(|e| refused(e, Input::N)),
            (Some(n), Some(k2)) => Saunderson::from_index(n, k2, Specular::Included)
                .map(Some)
                .map_err(|e| refused(e, Input::K2)),
        }
    }

    /// The fit of the inputs: [`DrawdownInputs::readings`], then
    /// [`DrawdownInputs::saunderson`], then [`fit_drawdown`].
    ///
    /// # Errors
    /// Those of the three, a refusal of [`fit_drawdown`] as
    /// [`InputError::Refused`] naming the input its message names.
    ///
    /// ```
    /// use km_inverse::drawdown::DrawdownInputs;
    /// let i = DrawdownInputs {
    ///     r_inf: Some(0.6), r_zero: Some(0.3), thickness: Some(2.0), ..Default::default()
    /// };
    /// let film = i.fit().unwrap().film.unwrap();
    /// assert!((film.k_over_s - 0.4 * 0.4 / (2.0 * 0.6)).abs() < 1e-15); // eq. I1
    /// ```
    pub fn fit(&self) -> Result<DrawdownFit, InputError> {
        let readings = self.readings()?;
        let corr = self.saunderson()?;
        fit_drawdown(readings, corr)
            .map_err(|source| InputError::Refused { input: Input::named_by(&source), source })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flag(i: Input) -> String {
        format!("--{}", i.name().replace('_', "-"))
    }

    /// Each rule of the module documentation, with the error it gives.
    #[test]
    fn missing_and_misplaced_inputs_are_named() {
        let base = DrawdownInputs::default();
        let cases: [(DrawdownInputs, InputError); 8] = [
            (base, InputError::NoReadings),
            (
                DrawdownInputs { r_black: Some(0.1), r_inf: Some(0.3), ..base },
                InputError::BothKinds,
            ),
            (
                DrawdownInputs { r_black: Some(0.1), ..base },
                InputError::Missing { needed: Input::RWhite, by: Some(Input::RBlack) },
            ),
            (
                DrawdownInputs { r_white: Some(0.1), ..base },
                InputError::Missing { needed: Input::RBlack, by: Some(Input::RWhite) },
            ),
            (
                DrawdownInputs { r_black: Some(0.1), r_white: Some(0.3), ..base },
                InputError::Missing { needed: Input::RWhiteGround, by: None },
            ),
            (
                DrawdownInputs { r_inf: Some(0.3), r_black_ground: Some(0.02), ..base },
                InputError::GroundWithoutFilm { ground: Input::RBlackGround },
            ),
            (
                DrawdownInputs { r_inf: Some(0.3), thickness: Some(1.0), ..base },
                InputError::ThicknessWithoutRZero,
            ),
            (
                DrawdownInputs { r_inf: Some(0.3), r_zero: Some(0.1), ..base },
                InputError::Missing { needed: Input::Thickness, by: None },
            ),
        ];
        for (inputs, want) in cases {
            assert_eq!(inputs.readings(), Err(want.clone()), "{inputs:?}");
            assert_eq!(inputs.fit().unwrap_err(), want);
        }
        // The messages in the command line's words.
        let e = DrawdownInputs { r_black: Some(0.1), r_white: Some(0.3), ..base }.readings();
        assert_eq!(
            e.unwrap_err().message(flag),
            "--r-white-ground (the reflectance of the light ground) is required"
        );
        assert_eq!(
            InputError::NoReadings.to_string(),
            "no readings: give r_black, r_white, r_white_ground and thickness, or r_inf \
             [r_zero thickness]"
        );
    }

    #[test]
    fn saunderson_from_n_and_k2() {
        let base = DrawdownInputs { r_inf: Some(0.5), ..Default::default() };
        assert_eq!(base.saunderson(), Ok(None));
        let k2_alone = DrawdownInputs { k2: Some(0.6), ..base };
        assert_eq!(
            k2_alone.saunderson().unwrap_err().message(flag),
            "--k2 needs --n (k1 is the Fresnel reflectance of the binder)"
        );
        // n = 1.5: k1 = ((n - 1)/(n + 1))^2 = 0.04 (eq. I8).
        let c = DrawdownInputs { n: Some(1.5), ..base }.saunderson().unwrap().unwrap();
        assert!((c.k1 - 0.04).abs() < 1e-15);
        let c = DrawdownInputs { n: Some(1.5), k2: Some(0.6), ..base }.saunderson().unwrap();
        assert_eq!(c.unwrap().k2, 0.6);
        // Out-of-range values are refused, naming the input.
        let e = DrawdownInputs { n: Some(0.5), ..base }.fit().unwrap_err();
        assert_eq!(e.input(), Some(Input::N));
        let e = DrawdownInputs { n: Some(1.5), k2: Some(1.5), ..base }.fit().unwrap_err();
        assert_eq!(e.input(), Some(Input::K2));
        assert!(e.to_string().contains("k2 = 1.5"), "{e}");
        // A reading below the surface reflection names the reading.
        let e = DrawdownInputs { r_inf: Some(0.01), n: Some(1.5), ..base }.fit().unwrap_err();
        assert_eq!(e.input(), Some(Input::RInf));
    }
}
