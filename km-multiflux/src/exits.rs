//! The distinct azimuths of a solve's exit directions with their
//! `cos m(phi - 180 deg)` (docs/multiflux.md §5): exit directions on a grid
//! share a few, so each cosine is computed once per azimuth and order.

/// The distinct azimuths of the exit directions.
pub(crate) struct Azimuths {
    /// The distinct azimuths (degrees), in order of first appearance.
    pub(crate) values: Vec<f64>,
    /// For each exit direction, its azimuth's index in `values`.
    pub(crate) of: Vec<usize>,
}

impl Azimuths {
    pub(crate) fn new(dirs: &[[f64; 2]]) -> Self {
        let mut values: Vec<f64> = Vec::new();
        let mut last: Option<(f64, usize)> = None;
        let of = dirs
            .iter()
            .map(|d| {
                // Runs of one azimuth (a grid listed azimuth-major) skip the search.
                if let Some((_, i)) = last.filter(|(p, _)| *p == d[1]) {
                    return i;
                }
                let i = match values.iter().position(|&p| p == d[1]) {
                    Some(i) => i,
                    None => {
                        values.push(d[1]);
                        values.len() - 1
                    }
                };
                last = Some((d[1], i));
                i
            })
            .collect();
        Azimuths { values, of }
    }

    /// `cos m(phi - 180 deg)` of every distinct azimuth into `out`.
    pub(crate) fn cos_order(&self, m: usize, out: &mut [f64]) {
        if m == 0 {
            // cos(0 x) = 1 exactly (the azimuths are finite).
            out.iter_mut().for_each(|c| *c = 1.0);
            return;
        }
        for (c, &phi) in out.iter_mut().zip(&self.values) {
            *c = (m as f64 * (phi - 180.0).to_radians()).cos();
        }
    }
}
