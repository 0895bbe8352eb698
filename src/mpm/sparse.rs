//! Symmetric sparse effective stiffness over the active nodes, assembled in 2×2 node blocks,
//! factorised by faer's sparse Cholesky with the symbolic analysis kept while the pattern
//! is unchanged (METHODS §3.3 steps 5–6).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Par, Side};
use nalgebra::{Matrix2, Vector2};

/// Lower-triangular block storage: block `(I, J)` with `I <= J` holds
/// `B[r][c] = K[2J + r][2I + c]`.
#[derive(Default)]
pub struct SymSystem {
    n_nodes: usize,
    block_col: Vec<usize>,
    block_row: Vec<usize>,
    blocks: Vec<Matrix2<f64>>,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// For each CSC value: `4 * block + 2 * r + c`.
    src: Vec<usize>,
    val: Vec<f64>,
    /// AMD ordering and supernodal structure (faer's simplicial heuristic picked the
    /// slower path for these 2D grid matrices: 54 % of the run time).
    symbolic: Option<SymbolicCholesky<usize>>,
    factor: Vec<f64>,
    factor_mem: Option<MemBuffer>,
    solve_mem: Option<MemBuffer>,
    /// Right-hand sides `solve_mem` is sized for.
    solve_cols: usize,
    /// Whether `factor` holds the factorisation of the current values.
    factored: bool,
    /// Whether the last `set_pattern` had to redo the symbolic analysis.
    pub new_symbolic: bool,
}

impl SymSystem {
    /// Sets the block pattern from node pairs `(I, J)`, `I <= J` (consumed; diagonal added).
    pub fn set_pattern(&mut self, n_nodes: usize, pairs: &mut Vec<(usize, usize)>) {
        pairs.extend((0..n_nodes).map(|i| (i, i)));
        pairs.sort_unstable();
        pairs.dedup();
        self.n_nodes = n_nodes;
        self.block_col.clear();
        self.block_row.clear();
        self.block_col.push(0);
        let mut col = 0;
        for &(i, j) in pairs.iter() {
            while col < i {
                self.block_col.push(self.block_row.len());
                col += 1;
            }
            self.block_row.push(j);
        }
        while self.block_col.len() <= n_nodes {
            self.block_col.push(self.block_row.len());
        }
        self.blocks.clear();
        self.blocks.resize(self.block_row.len(), Matrix2::zeros());

        let (old_ptr, old_idx) = (
            std::mem::take(&mut self.col_ptr),
            std::mem::take(&mut self.row_idx),
        );
        self.src.clear();
        self.col_ptr.push(0);
        for i in 0..n_nodes {
            for c in 0..2 {
                for b in self.block_col[i]..self.block_col[i + 1] {
                    let j = self.block_row[b];
                    for r in 0..2 {
                        if j == i && r < c {
                            continue;
                        }
                        self.row_idx.push(2 * j + r);
                        self.src.push(4 * b + 2 * r + c);
                    }
                }
                self.col_ptr.push(self.row_idx.len());
            }
        }
        self.val.clear();
        self.val.resize(self.row_idx.len(), 0.0);
        self.new_symbolic = old_ptr != self.col_ptr || old_idx != self.row_idx;
        if self.new_symbolic {
            self.symbolic = None;
        }
        self.factored = false;
    }

    pub fn zero(&mut self) {
        self.blocks.iter_mut().for_each(|b| *b = Matrix2::zeros());
    }

    fn find(&self, i: usize, j: usize) -> usize {
        let rows = &self.block_row[self.block_col[i]..self.block_col[i + 1]];
        self.block_col[i]
            + rows
                .binary_search(&j)
                .expect("pair outside the block pattern")
    }

    /// Index of the block `K[2I.., 2J..]`, `I >= J` (the lower triangle), for `add_block`;
    /// valid until the next `set_pattern`.
    pub fn lower_block(&self, i: usize, j: usize) -> usize {
        self.find(j, i)
    }

    /// Adds `k` to the block numbered `b` by `lower_block`.
    pub fn add_block(&mut self, b: usize, k: &Matrix2<f64>) {
        self.blocks[b] += k;
    }

    /// Adds `k` to the diagonal block of node `i`.
    pub fn add_diag(&mut self, i: usize, k: f64) {
        let b = self.find(i, i);
        self.blocks[b][(0, 0)] += k;
        self.blocks[b][(1, 1)] += k;
    }

    /// Diagonal entry `K[d][d]`.
    pub fn diag(&self, d: usize) -> f64 {
        let b = self.find(d / 2, d / 2);
        self.blocks[b][(d % 2, d % 2)]
    }

    /// `y = K x` with the full symmetric matrix.
    pub fn matvec(&self, x: &[f64], y: &mut [f64]) {
        y.iter_mut().for_each(|v| *v = 0.0);
        for i in 0..self.n_nodes {
            for b in self.block_col[i]..self.block_col[i + 1] {
                let j = self.block_row[b];
                let k = &self.blocks[b];
                let (xi0, xi1, xj0, xj1) = (x[2 * i], x[2 * i + 1], x[2 * j], x[2 * j + 1]);
                if i == j {
                    y[2 * i] += k[(0, 0)] * xi0 + k[(1, 0)] * xi1;
                    y[2 * i + 1] += k[(1, 0)] * xi0 + k[(1, 1)] * xi1;
                } else {
                    y[2 * j] += k[(0, 0)] * xi0 + k[(0, 1)] * xi1;
                    y[2 * j + 1] += k[(1, 0)] * xi0 + k[(1, 1)] * xi1;
                    y[2 * i] += k[(0, 0)] * xj0 + k[(1, 0)] * xj1;
                    y[2 * i + 1] += k[(0, 1)] * xj0 + k[(1, 1)] * xj1;
                }
            }
        }
    }

    /// Solves `K x = rhs` in place, with the DOFs in `fixed` eliminated (their rows and
    /// columns reduced to the diagonal; the caller has moved their coupling to `rhs`).
    pub fn solve(&mut self, fixed: &[bool], rhs: &mut [f64]) -> Result<(), String> {
        self.factorize(fixed)?;
        self.solve_factored(rhs, 1)
    }

    /// Numeric Cholesky factorisation of `K` with the DOFs in `fixed` eliminated (kept for
    /// `solve_factored` until the next `factorize`).
    pub fn factorize(&mut self, fixed: &[bool]) -> Result<(), String> {
        for (k, s) in self.src.iter().enumerate() {
            let (b, r, c) = (s / 4, (s % 4) / 2, s % 2);
            self.val[k] = self.blocks[b][(r, c)];
        }
        for c in 0..2 * self.n_nodes {
            for k in self.col_ptr[c]..self.col_ptr[c + 1] {
                let r = self.row_idx[k];
                if r != c && (fixed[r] || fixed[c]) {
                    self.val[k] = 0.0;
                }
            }
        }
        let n = 2 * self.n_nodes;
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
        // Sequential: the systems are small (a few thousand DOFs) and the machine shared;
        // packings solve their grains in parallel instead.
        let par = Par::Seq;
        if self.symbolic.is_none() {
            let params = CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                ..Default::default()
            };
            let symbolic =
                factorize_symbolic_cholesky(sym, Side::Lower, SymmetricOrdering::Amd, params)
                    .map_err(|e| format!("{e:?}"))?;
            self.factor.clear();
            self.factor.resize(symbolic.len_val(), 0.0);
            self.factor_mem = Some(MemBuffer::new(
                symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()),
            ));
            self.solve_mem = None;
            self.solve_cols = 0;
            self.symbolic = Some(symbolic);
        }
        let (Some(symbolic), Some(fmem)) = (&self.symbolic, &mut self.factor_mem) else {
            return Err("no symbolic factorisation".into());
        };
        self.factored = false;
        symbolic
            .factorize_numeric_llt::<f64>(
                &mut self.factor,
                SparseColMatRef::new(sym, &self.val),
                Side::Lower,
                Default::default(),
                par,
                MemStack::new(fmem),
                Default::default(),
            )
            .map_err(|e| format!("{e:?}"))?;
        self.factored = true;
        Ok(())
    }

    /// Solves `K X = B` in place for `cols` right-hand sides stored column after column in
    /// `rhs`, with the last factorisation.
    pub fn solve_factored(&mut self, rhs: &mut [f64], cols: usize) -> Result<(), String> {
        let n = 2 * self.n_nodes;
        let Some(symbolic) = self.symbolic.as_ref().filter(|_| self.factored) else {
            return Err("solve before factorisation".into());
        };
        if rhs.len() != n * cols {
            return Err(format!("{} values for {cols} columns of {n}", rhs.len()));
        }
        let par = Par::Seq;
        if self.solve_mem.is_none() || self.solve_cols < cols {
            self.solve_mem = Some(MemBuffer::new(
                symbolic.solve_in_place_scratch::<f64>(cols, par),
            ));
            self.solve_cols = cols;
        }
        let smem = self.solve_mem.as_mut().expect("allocated above");
        LltRef::new(symbolic, &self.factor).solve_in_place_with_conj(
            Conj::No,
            faer::MatMut::from_column_major_slice_mut(rhs, n, cols),
            par,
            MemStack::new(smem),
        );
        Ok(())
    }

    /// Solves `K x = rhs` in place by conjugate gradients with a block-Jacobi (2×2 node
    /// block) preconditioner, the DOFs in `fixed` eliminated as in `factorize`, from
    /// `x = 0` until `‖r‖ <= tol ‖rhs‖`. Returns the iterations. The measured alternative to
    /// the Cholesky factorisation (`benches/linear_solver.rs`; README, "MPM").
    pub fn solve_pcg(
        &self,
        fixed: &[bool],
        rhs: &mut [f64],
        tol: f64,
        max_iterations: usize,
    ) -> Result<usize, String> {
        let n = 2 * self.n_nodes;
        // Inverse diagonal blocks, with fixed DOFs decoupled.
        let inv: Vec<Matrix2<f64>> = (0..self.n_nodes)
            .map(|i| {
                let mut k = self.blocks[self.block_col[i]];
                for a in 0..2 {
                    if fixed[2 * i + a] {
                        k[(a, 1 - a)] = 0.0;
                        k[(1 - a, a)] = 0.0;
                    }
                }
                k[(0, 1)] = k[(1, 0)];
                k.try_inverse().unwrap_or_else(Matrix2::zeros)
            })
            .collect();
        // A fixed DOF keeps only its diagonal, as in `factorize`.
        let fixed_diag: Vec<(usize, f64)> = (0..n)
            .filter(|&d| fixed[d])
            .map(|d| (d, self.diag(d)))
            .collect();
        let apply = |x: &[f64], y: &mut [f64], masked: &mut [f64]| {
            masked.copy_from_slice(x);
            for &(d, _) in &fixed_diag {
                masked[d] = 0.0;
            }
            self.matvec(masked, y);
            for &(d, k) in &fixed_diag {
                y[d] = k * x[d];
            }
        };
        let precondition = |r: &[f64], z: &mut [f64]| {
            for (i, m) in inv.iter().enumerate() {
                let v = m * Vector2::new(r[2 * i], r[2 * i + 1]);
                z[2 * i] = v.x;
                z[2 * i + 1] = v.y;
            }
        };
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let mut r = rhs.to_vec();
        let target = tol * dot(&r, &r).sqrt();
        let (mut x, mut z, mut q, mut scratch) =
            (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        precondition(&r, &mut z);
        let mut p = z.clone();
        let mut rz = dot(&r, &z);
        for it in 0..max_iterations {
            if dot(&r, &r).sqrt() <= target {
                rhs.copy_from_slice(&x);
                return Ok(it);
            }
            apply(&p, &mut q, &mut scratch);
            let alpha = rz / dot(&p, &q);
            for d in 0..n {
                x[d] += alpha * p[d];
                r[d] -= alpha * q[d];
            }
            precondition(&r, &mut z);
            let rz_new = dot(&r, &z);
            let beta = rz_new / rz;
            rz = rz_new;
            for d in 0..n {
                p[d] = z[d] + beta * p[d];
            }
        }
        Err(format!("CG: no convergence in {max_iterations} iterations"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_small_spd_system_with_a_fixed_dof() {
        // Chain of 3 nodes, springs along both axes, plus mass on the diagonal.
        let mut s = SymSystem::default();
        let mut pairs = vec![(0, 1), (1, 2)];
        s.set_pattern(3, &mut pairs);
        assert!(s.new_symbolic);
        let k = Matrix2::new(2.0, 0.5, 0.5, 1.0);
        for (i, j) in [(0, 1), (1, 2)] {
            s.add_block(s.lower_block(i, i), &k);
            s.add_block(s.lower_block(j, j), &k);
            s.add_block(s.lower_block(j, i), &(-k));
        }
        for i in 0..3 {
            s.add_diag(i, 1.0);
        }
        let x: Vec<f64> = (0..6).map(|i| i as f64 - 1.5).collect();
        let mut b = vec![0.0; 6];
        s.matvec(&x, &mut b);
        s.solve(&[false; 6], &mut b).unwrap();
        for (a, e) in b.iter().zip(&x) {
            assert!((a - e).abs() < 1e-12);
        }
        // one factorisation, two right-hand sides at once (the condensed compliance)
        s.factorize(&[false; 6]).unwrap();
        let y: Vec<f64> = (0..6).map(|i| (i * i) as f64 - 2.0).collect();
        let (mut bx, mut by) = (vec![0.0; 6], vec![0.0; 6]);
        s.matvec(&x, &mut bx);
        s.matvec(&y, &mut by);
        let mut both = [bx, by].concat();
        s.solve_factored(&mut both, 2).unwrap();
        for (a, e) in both.iter().zip(x.iter().chain(&y)) {
            assert!((a - e).abs() < 1e-12);
        }
        // conjugate gradients give the same solution, with the fixed DOF eliminated alike
        let fixed = [false, false, true, false, false, false];
        let mut b = vec![0.0; 6];
        s.matvec(&x, &mut b);
        let (mut direct, mut iterative) = (b.clone(), b.clone());
        s.solve(&fixed, &mut direct).unwrap();
        let iterations = s.solve_pcg(&fixed, &mut iterative, 1e-14, 50).unwrap();
        assert!(iterations <= 6, "{iterations}");
        for (a, e) in iterative.iter().zip(&direct) {
            assert!((a - e).abs() < 1e-12, "{a} {e}");
        }
        let mut pairs = vec![(0, 1), (1, 2)];
        s.set_pattern(3, &mut pairs);
        assert!(!s.new_symbolic);
        assert!(s.solve_factored(&mut [0.0; 6], 1).is_err());
    }
}
