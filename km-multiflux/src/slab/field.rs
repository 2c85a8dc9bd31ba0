//! The radiance field inside one layer at any depth (seed eq. 19 in the
//! scaled form S4).

use super::{SlabSolution, atten};
use crate::MultifluxError;

impl SlabSolution {
    /// The radiance field inside the layer at optical depth `tau` (seed 000
    /// eq. 19, in the scaled form S4): down-going `I+` and up-going `I-` at
    /// the nodes, for down-going radiances `top_in` entering at the top,
    /// up-going `bottom_in` entering at the bottom, and optionally a beam
    /// `(mu_b, F)` of horizontal irradiance `F` entering at the top. Radiances
    /// are the Fourier component of order `m` of this solution.
    ///
    /// ```text
    ///   I~± = 1/2 v [s (e1+e2)/2 + y D/2] ± 1/2 z [s k (e1-e2)/2 + y (e1+e2)/2]
    ///   e1 = e^{-k tau}, e2 = e^{-k (tau0 - tau)}, D = (e1 - e2)/k (-> tau0 - 2 tau)
    /// ```
    ///
    /// plus the particular solution `Z± F e^{-tau/mu_b}` (eq. S6).
    ///
    /// # Errors
    /// [`MultifluxError::Shape`] if the inputs do not have one value per node,
    /// [`MultifluxError::Option`] if `tau` lies outside `[0, tau0]`.
    pub fn field(
        &self,
        tau: f64,
        top_in: &[f64],
        bottom_in: &[f64],
        beam: Option<(f64, f64)>,
    ) -> Result<(Vec<f64>, Vec<f64>), MultifluxError> {
        let n = self.n;
        if top_in.len() != n || bottom_in.len() != n {
            return Err(MultifluxError::Shape {
                what: "field",
                detail: format!("{n} nodes, inputs {} and {}", top_in.len(), bottom_in.len()),
            });
        }
        if !(0.0..=self.tau).contains(&tau) || tau.is_infinite() {
            return Err(MultifluxError::Option {
                name: "tau",
                value: tau,
                reason: "depth must lie in [0, tau0] and be finite",
            });
        }
        // Boundary values of the homogeneous part (transformed coordinates).
        let (mut a, mut b) = (top_in.to_vec(), bottom_in.to_vec());
        let mut part = None;
        if let Some((mu_b, f)) = beam {
            let (zp, zm) = crate::workspace::with_workspace(|ws| self.particular(mu_b, ws));
            let eb = atten(self.tau, mu_b);
            for i in 0..n {
                a[i] -= f * zp[i];
                b[i] -= f * zm[i] * eb;
            }
            let e = (-tau / mu_b).exp() * f;
            part = Some((
                zp.iter().map(|x| x * e).collect::<Vec<_>>(),
                zm.iter().map(|x| x * e).collect::<Vec<_>>(),
            ));
        }
        let at: Vec<f64> = (0..n).map(|i| a[i] * self.t[i]).collect();
        let bt: Vec<f64> = (0..n).map(|i| b[i] * self.t[i]).collect();
        let half = self.tau.is_infinite();
        // s = Cp^-1 (a~ + b~), y = Cm^-1 (a~ - b~) (eq. S4).
        let mut s: Vec<f64> = (0..n).map(|i| at[i] + if half { 0.0 } else { bt[i] }).collect();
        self.lu_p.solve(&mut s);
        let mut y: Vec<f64> = (0..n).map(|i| at[i] - bt[i]).collect();
        match &self.lu_m {
            Some(lu) => lu.solve(&mut y),
            None => y.iter_mut().for_each(|x| *x = 0.0),
        }
        let (mut dn, mut up) = (vec![0.0; n], vec![0.0; n]);
        for j in 0..n {
            let k = self.k[j];
            let e1 = (-k * tau).exp();
            let (cv, cz) = if half {
                // Only top-anchored modes: c = s.
                (0.5 * s[j] * e1, 0.5 * s[j] * k * e1)
            } else {
                let e2 = (-k * (self.tau - tau)).exp();
                let d = if k > 0.0 { (e1 - e2) / k } else { self.tau - 2.0 * tau };
                (
                    0.5 * (0.5 * s[j] * (e1 + e2) + 0.5 * y[j] * d),
                    0.5 * (0.5 * s[j] * k * (e1 - e2) + 0.5 * y[j] * (e1 + e2)),
                )
            };
            for i in 0..n {
                dn[i] += cv * self.v[(i, j)] + cz * self.z[(i, j)];
                up[i] += cv * self.v[(i, j)] - cz * self.z[(i, j)];
            }
        }
        for i in 0..n {
            dn[i] /= self.t[i];
            up[i] /= self.t[i];
        }
        if let Some((zp, zm)) = part {
            for i in 0..n {
                dn[i] += zp[i];
                up[i] += zm[i];
            }
        }
        Ok((dn, up))
    }
}
