//! Anderson acceleration of the NLGS (type II, Walker & Ni 2011), an option
//! (`solver.anderson`, the history depth m; 0 = off). The MPM surface contact's NLGS uses it
//! too, on the contact forces with one sweep per block (`mpm::node_contact::nlgs`).
//!
//! A block of Gauss-Seidel sweeps is a fixed-point map p ↦ G(p) on the impulses (p_n, p_t).
//! With the residuals f = G(p) - p of the last m + 1 blocks, the next iterate is the
//! combination of their outputs whose residuals cancel best in the least-squares sense:
//! γ = argmin |f_k - ΔF γ|_W, p_{k+1} = G(p_k) - ΔG γ, brought back onto each contact's
//! admissible set. On a linear problem this is GMRES(m) on the sweep; on a pile, whose slow
//! error is the load spreading through many contacts, it replaces the many sweeps plain
//! Gauss-Seidel needs to pass that load on. The residual is weighted by the diagonal
//! Delassus terms (a velocity, as in the QuadDV norm). The history restarts when a block's
//! residual grows (the contact statuses changed and the old directions no longer apply).
//! Convergence is still judged on a plain Gauss-Seidel sweep, so the stopping test, hence
//! the solution's accuracy, is the same as without acceleration.

/// The history and the block's starting impulses. Vectors are indexed by slot: the row
/// given slot `s` at `reset` owns entry `offset[s]` (p_n) and, if it is frictional,
/// `offset[s] + 1` (p_t), and keeps its slot through the shuffles between blocks. A
/// frictionless row's p_t is 0 throughout, so it is left out: every sum over the vectors
/// then skips only exact zeros, and a frictionless solve's vectors are half as long.
#[derive(Clone, Debug, Default)]
pub struct Anderson {
    depth: usize,
    /// First entry of each slot, and the length last (a slot has one or two entries).
    offset: Vec<u32>,
    /// Residual weights W_nn (and W_tt) by entry.
    weight: Vec<f64>,
    /// Impulses at the start of the current block (x_k).
    start: Vec<f64>,
    /// This block's output and residual (g_k, f_k), then the previous block's.
    g: Vec<f64>,
    f: Vec<f64>,
    prev_g: Vec<f64>,
    prev_f: Vec<f64>,
    prev_norm: Option<f64>,
    /// Columns ΔG and ΔF, oldest first; popped columns are reused.
    dg: std::collections::VecDeque<Vec<f64>>,
    df: std::collections::VecDeque<Vec<f64>>,
    /// Weighted Gram matrix of the ΔF columns, kept in step with them.
    gram: std::collections::VecDeque<std::collections::VecDeque<f64>>,
    /// The accelerated iterate, by slot.
    next: Vec<f64>,
    /// Columns dropped by a restart or a `reset`, reused before allocating new ones.
    spare: Vec<Vec<f64>>,
}

/// Slots per chunk of the passes over the columns: a chunk of each of the m + 2 arrays a
/// pass reads (about 20 KiB at m = 8) fits in L1.
const CHUNK: usize = 256;

impl Anderson {
    /// Starts a new solve with an empty history, keeping the buffers' memory (the scene
    /// keeps one `Anderson` from step to step). `rows`: the diagonal terms (W_nn, W_tt) of
    /// the contacts in the solve and whether each is frictional, by slot.
    pub fn reset(&mut self, depth: usize, rows: impl Iterator<Item = (f64, f64, bool)>) {
        self.depth = depth;
        self.weight.clear();
        self.offset.clear();
        for (w_nn, w_tt, frictional) in rows {
            self.offset.push(self.weight.len() as u32);
            self.weight.push(w_nn);
            if frictional {
                self.weight.push(w_tt);
            }
        }
        let n = self.weight.len();
        self.offset.push(n as u32);
        for v in [
            &mut self.start,
            &mut self.g,
            &mut self.f,
            &mut self.prev_g,
            &mut self.prev_f,
            &mut self.next,
        ] {
            v.clear();
            v.resize(n, 0.0);
        }
        self.prev_norm = None;
        self.forget();
    }

    /// Empties the history, keeping its columns for reuse.
    fn forget(&mut self) {
        self.spare
            .extend(self.dg.drain(..).chain(self.df.drain(..)));
        self.gram.clear();
    }

    fn gather(out: &mut [f64], offset: &[u32], impulses: impl Iterator<Item = (usize, f64, f64)>) {
        for (slot, p_n, p_t) in impulses {
            let (s, end) = (offset[slot] as usize, offset[slot + 1] as usize);
            out[s] = p_n;
            if end > s + 1 {
                out[s + 1] = p_t;
            }
        }
    }

    /// Records x_k, the impulses (slot, p_n, p_t) at the start of a block.
    pub fn begin(&mut self, impulses: impl Iterator<Item = (usize, f64, f64)>) {
        Self::gather(&mut self.start, &self.offset, impulses);
    }

    /// Given g_k, the block's output, returns the accelerated iterate before projection as
    /// a function of the slot, or None while the history is empty.
    pub fn next(
        &mut self,
        output: impl Iterator<Item = (usize, f64, f64)>,
    ) -> Option<impl Fn(usize) -> (f64, f64) + '_> {
        Self::gather(&mut self.g, &self.offset, output);
        let mut norm = 0.0;
        for (i, f) in self.f.iter_mut().enumerate() {
            *f = self.g[i] - self.start[i];
            let wf = self.weight[i] * *f;
            norm += wf * wf;
        }
        let rhs = match self.prev_norm {
            // the residual grew: the statuses changed, the old directions no longer apply
            Some(prev) if norm > prev => {
                self.forget();
                None
            }
            Some(_) => {
                let (mut dg, mut df) = if self.dg.len() == self.depth {
                    self.gram.pop_front();
                    for row in self.gram.iter_mut() {
                        row.pop_front();
                    }
                    (
                        self.dg.pop_front().expect("full"),
                        self.df.pop_front().expect("full"),
                    )
                } else {
                    // every entry is written below
                    let n = self.g.len();
                    let mut column = || {
                        let mut v = self.spare.pop().unwrap_or_default();
                        v.resize(n, 0.0);
                        v
                    };
                    (column(), column())
                };
                for i in 0..self.g.len() {
                    dg[i] = self.g[i] - self.prev_g[i];
                    df[i] = self.f[i] - self.prev_f[i];
                }
                self.dg.push_back(dg);
                self.df.push_back(df);
                let (new, rhs) = self.dots();
                for (row, &v) in self.gram.iter_mut().zip(&new) {
                    row.push_back(v);
                }
                self.gram.push_back(new.into());
                Some(rhs)
            }
            None => None,
        };
        self.prev_norm = Some(norm);
        let gamma = rhs.and_then(|b| self.coefficients(b));
        std::mem::swap(&mut self.g, &mut self.prev_g);
        std::mem::swap(&mut self.f, &mut self.prev_f);
        let gamma = gamma?;
        // next = g_k - ΔG γ, the columns subtracted in order for each element (a chunk of
        // elements at a time, so that the columns stay in cache and the loop vectorises)
        for (start, chunk) in self.next.chunks_mut(CHUNK).enumerate() {
            let at = start * CHUNK..start * CHUNK + chunk.len();
            chunk.copy_from_slice(&self.prev_g[at.clone()]);
            for (col, &c) in self.dg.iter().zip(&gamma) {
                for (x, &d) in chunk.iter_mut().zip(&col[at.clone()]) {
                    *x -= c * d;
                }
            }
        }
        Some(|slot: usize| {
            let (s, end) = (self.offset[slot] as usize, self.offset[slot + 1] as usize);
            (
                self.next[s],
                if end > s + 1 { self.next[s + 1] } else { 0.0 },
            )
        })
    }

    /// The Gram matrix's new last row and column, Σ W² ΔF_j ΔF_new for every column j (the
    /// new one last), and the right-hand side Σ W² ΔF_j f, a chunk of slots at a time for
    /// all columns (they do not fit in cache at 10⁵ contacts). Each sum runs over the slots
    /// in order, as a dot product at a time would.
    fn dots(&self) -> (Vec<f64>, Vec<f64>) {
        let new = self.df.back().expect("a new column");
        let (w, f) = (&self.weight, &self.f);
        // -0.0: the neutral element `Iterator::sum` starts from
        let mut gram = vec![-0.0; self.df.len()];
        let mut rhs = vec![-0.0; self.df.len()];
        for start in (0..w.len()).step_by(CHUNK) {
            let at = start..(start + CHUNK).min(w.len());
            for ((col, g), r) in self.df.iter().zip(&mut gram).zip(&mut rhs) {
                let (mut sg, mut sr) = (*g, *r);
                for i in at.clone() {
                    let a = w[i] * w[i] * col[i];
                    sg += a * new[i];
                    sr += a * f[i];
                }
                (*g, *r) = (sg, sr);
            }
        }
        (gram, rhs)
    }

    /// γ from the weighted normal equations (ΔFᵀ W² ΔF) γ = ΔFᵀ W² f (`b`, from `dots`), with
    /// a small Tikhonov term for nearly dependent columns.
    fn coefficients(&self, b: Vec<f64>) -> Option<Vec<f64>> {
        let m = self.df.len();
        let trace: f64 = (0..m).map(|i| self.gram[i][i]).sum();
        if trace <= 0.0 {
            return None;
        }
        let a = nalgebra::DMatrix::from_fn(m, m, |i, j| {
            self.gram[i][j] + if i == j { 1e-10 * trace } else { 0.0 }
        });
        let b = nalgebra::DVector::from_vec(b);
        let gamma = a.cholesky()?.solve(&b);
        gamma
            .iter()
            .all(|v| v.is_finite())
            .then(|| gamma.iter().copied().collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a linear fixed point x = A x + b (a contraction), Anderson converges far faster
    /// than the plain iteration.
    #[test]
    fn accelerates_a_linear_fixed_point() {
        // two slots (one contact), G(x) = 0.95 R x + c with R a rotation-like coupling
        let g = |x: &[f64; 2]| -> [f64; 2] {
            [
                0.9 * x[0] + 0.05 * x[1] + 1.0,
                0.05 * x[0] + 0.9 * x[1] + 2.0,
            ]
        };
        let exact = {
            // (I - A) x = c
            let (a, b, c, d) = (0.1, -0.05, -0.05, 0.1);
            let det = a * d - b * c;
            [(d * 1.0 - b * 2.0) / det, (-c * 1.0 + a * 2.0) / det]
        };
        let mut plain = [0.0, 0.0];
        for _ in 0..20 {
            plain = g(&plain);
        }
        let mut aa = Anderson::default();
        aa.reset(2, std::iter::once((1.0, 1.0, true)));
        let mut x = [0.0, 0.0];
        for _ in 0..20 {
            aa.begin(std::iter::once((0, x[0], x[1])));
            let gx = g(&x);
            x = match aa.next(std::iter::once((0, gx[0], gx[1]))) {
                Some(at) => at(0).into(),
                None => gx,
            };
        }
        let err = |v: [f64; 2]| ((v[0] - exact[0]).powi(2) + (v[1] - exact[1]).powi(2)).sqrt();
        assert!(err(x) < 1e-8 * err([0.0, 0.0]), "anderson error {}", err(x));
        assert!(
            err(plain) > 0.1 * err([0.0, 0.0]),
            "plain error {}",
            err(plain)
        );
    }
}
