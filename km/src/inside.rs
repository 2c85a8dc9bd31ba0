//! The radiance inside a stack at depths and directions: the answer's type,
//! made by the multi-flux route ([`crate::field`]) and the Monte Carlo one
//! ([`crate::mc_field::mc_inside`]) alike (docs/field.md §2a, §4a).

/// The radiance inside the stack at the field's depths and some directions.
#[derive(Debug, Clone, PartialEq)]
pub struct InsideField {
    /// The directions `[theta, phi]`, degrees: `theta` from the downward
    /// normal (`< 90` down-going, `> 90` up-going), `phi = 180` the side
    /// towards which the beam travels.
    pub directions: Vec<[f64; 2]>,
    /// `radiance[c][k][j]`: channel `c`, depth `k`, direction `j`; the
    /// diffuse radiance per unit incident irradiance (1/sr), the collimated
    /// beams apart.
    pub radiance: Vec<Vec<Vec<f64>>>,
    /// Their standard errors (Monte Carlo).
    pub stderr: Option<Vec<Vec<Vec<f64>>>>,
    /// Per channel and depth, the down-going and up-going collimated beams'
    /// irradiance on a horizontal plane (multi-flux; delta-M scaled, the
    /// truncated forward peak with them).
    pub beams: Option<[Vec<Vec<f64>>; 2]>,
    /// The Monte Carlo cone half-angle of each direction, degrees (its
    /// resolution: the values are cone averages).
    pub cone_half_angle_deg: Option<Vec<f64>>,
}
