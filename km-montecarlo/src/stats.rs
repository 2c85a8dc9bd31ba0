//! Batch statistics: the sums of eq. T1 (docs/montecarlo.md §5) kept batch
//! by batch, their means and standard errors, and those of quantities
//! derived from each batch's sums.

/// Running batch statistics of one channel: the sums of eq. T1 accumulated
/// batch by batch in batch-index order (so the result is a deterministic
/// function of the batch sums).
#[derive(Debug, Clone)]
pub(crate) struct BatchStats {
    /// Photons so far.
    pub n: u64,
    /// Batches so far.
    pub batches: u64,
    /// Sum over batches of `S_b` per tally.
    pub sum: Vec<f64>,
    /// Per batch, the sums (kept for the second pass of eq. T1).
    per_batch: Vec<(u64, Vec<f64>)>,
}

impl BatchStats {
    pub fn new(len: usize) -> Self {
        BatchStats { n: 0, batches: 0, sum: vec![0.0; len], per_batch: Vec::new() }
    }

    /// Add one batch (call in batch-index order).
    pub fn push(&mut self, photons: u64, sums: &[f64]) {
        self.n += photons;
        self.batches += 1;
        for (a, b) in self.sum.iter_mut().zip(sums) {
            *a += *b;
        }
        self.per_batch.push((photons, sums.to_vec()));
    }

    /// Mean per photon of tally `j` (eq. T1).
    pub fn mean(&self, j: usize) -> f64 {
        self.sum[j] / self.n as f64
    }

    /// Mean and standard error (eq. T1) of a quantity derived from each
    /// batch's sums, `f(sums, photons)`, linear in the sums (so that its
    /// batch values are the `S_b` of eq. T1).
    pub fn derived(&self, f: impl Fn(&[f64], f64) -> f64) -> (f64, f64) {
        let vals: Vec<(f64, f64)> =
            self.per_batch.iter().map(|(nb, s)| (*nb as f64, f(s, *nb as f64))).collect();
        let n = self.n as f64;
        let x = vals.iter().map(|v| v.1).sum::<f64>() / n;
        if self.batches < 2 {
            return (x, f64::NAN);
        }
        let ss: f64 = vals.iter().map(|(nb, v)| (v - x * nb).powi(2)).sum();
        let b = self.batches as f64;
        (x, (b / (b - 1.0) * ss).sqrt() / n)
    }

    /// Standard error of the mean of tally `j` (eq. T1); NaN with one batch.
    pub fn stderr(&self, j: usize) -> f64 {
        if self.batches < 2 {
            return f64::NAN;
        }
        let x = self.mean(j);
        let ss: f64 = self
            .per_batch
            .iter()
            .map(|(nb, s)| {
                let d = s[j] - x * *nb as f64;
                d * d
            })
            .sum();
        let b = self.batches as f64;
        (b / (b - 1.0) * ss).sqrt() / self.n as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_batches_give_textbook_standard_error() {
        // Batch means 1, 2, 3, 4 of 10 photons each: s^2 = 5/3, se = sqrt(5/3 / 4).
        let mut s = BatchStats::new(1);
        for m in [1.0, 2.0, 3.0, 4.0] {
            s.push(10, &[10.0 * m]);
        }
        assert!((s.mean(0) - 2.5).abs() < 1e-15);
        assert!((s.stderr(0) - (5.0f64 / 3.0 / 4.0).sqrt()).abs() < 1e-15);
    }
}
