//! Symmetric sparse effective stiffness over the active nodes, assembled in 2×2 node blocks,
//! factorised by faer's sparse Cholesky with the symbolic analysis kept while the pattern
//! is unchanged (METHODS §3.3 steps 5–6).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::supernodal::{
    SupernodalLltRef, SymbolicSupernodalCholesky, factorize_supernodal_numeric_llt,
    factorize_supernodal_numeric_llt_scratch,
};
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::{Accum, Conj, Par, Side};
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
    /// AMD ordering and supernodal structure (faer's simplicial heuristic picked the
    /// slower path for these 2D grid matrices: 54 % of the run time).
    symbolic: Option<SymbolicCholesky<usize>>,
    /// The lower triangle in the AMD order, filled straight from the blocks (faer would
    /// otherwise permute the matrix at every factorisation).
    permuted: Option<Permuted>,
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

/// The supernodal structure of `symbolic` (`factorize` forces it).
fn supernodal(
    symbolic: &SymbolicCholesky<usize>,
) -> Result<&SymbolicSupernodalCholesky<usize>, String> {
    match symbolic.raw() {
        SymbolicCholeskyRaw::Supernodal(s) => Ok(s),
        SymbolicCholeskyRaw::Simplicial(_) => Err("simplicial symbolic factorisation".into()),
    }
}

/// The solves' scratch `mem`, grown to `cols` right-hand sides (`sized` holds how many it
/// takes).
fn solve_stack<'m>(
    mem: &'m mut Option<MemBuffer>,
    sized: &mut usize,
    symbolic: &SymbolicCholesky<usize>,
    cols: usize,
) -> &'m mut MemBuffer {
    if mem.is_none() || *sized < cols {
        *sized = cols;
        *mem = Some(MemBuffer::new(
            symbolic.solve_in_place_scratch::<f64>(cols, Par::Seq),
        ));
    }
    mem.as_mut().expect("allocated above")
}

/// Clears the upper halves of the AVX registers (`vzeroupper`). faer's triangular
/// product returns without it, and the SSE code compiled for the baseline target that runs
/// next on the thread then pays a transition penalty on every vector instruction: after it
/// the NLGS ran 1.4-2.1 times and the stiffness assembly 2.4 times slower (16 grains; a
/// dummy product of the same size in the old build, same bits: NLGS 6.5 s, 3.7 s without
/// the product, 3.9 s with the product and this clear; `bench/README-packings.md`).
fn clear_upper_state() {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx")]
        fn zero_upper() {
            std::arch::x86_64::_mm256_zeroupper();
        }
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU has AVX (checked just above)
            unsafe { zero_upper() }
        }
    }
}

/// The lower triangle of `Q K Qᵀ` (`Q` the symbolic factorisation's fill-reducing order):
/// its pattern, for each value the block entry it comes from (`4 * block + 2 * r + c`), and
/// `fwd[i]`, the DOF at position `i` of the order.
struct Permuted {
    pattern: SymbolicSparseColMat<usize>,
    src: Vec<usize>,
    fwd: Vec<usize>,
    val: Vec<f64>,
}

impl Permuted {
    fn new(
        col_ptr: &[usize],
        row_idx: &[usize],
        src: &[usize],
        symbolic: &SymbolicCholesky<usize>,
    ) -> Permuted {
        let n = col_ptr.len() - 1;
        let (fwd, inv): (Vec<usize>, Vec<usize>) = match symbolic.perm() {
            Some(perm) => (perm.arrays().0.to_vec(), perm.arrays().1.to_vec()),
            None => ((0..n).collect(), (0..n).collect()),
        };
        // entry k of column c, row r ≥ c, lands at (max, min) of (inv[r], inv[c])
        let at = |k: usize, c: usize| {
            let (r2, c2) = (inv[row_idx[k]], inv[c]);
            (r2.max(c2), r2.min(c2))
        };
        let mut ptr = vec![0; n + 1];
        for c in 0..n {
            for k in col_ptr[c]..col_ptr[c + 1] {
                ptr[at(k, c).1 + 1] += 1;
            }
        }
        for c in 0..n {
            ptr[c + 1] += ptr[c];
        }
        let nnz = row_idx.len();
        let mut next = ptr.clone();
        let (mut rows, mut psrc) = (vec![0; nnz], vec![0; nnz]);
        for c in 0..n {
            let span = col_ptr[c]..col_ptr[c + 1];
            for (k, &s) in span.clone().zip(&src[span]) {
                let (r2, c2) = at(k, c);
                let slot = next[c2];
                next[c2] += 1;
                rows[slot] = r2;
                psrc[slot] = s;
            }
        }
        let pattern = SymbolicSparseColMat::new_unsorted_checked(n, n, ptr, None, rows);
        Permuted {
            pattern,
            src: psrc,
            fwd,
            val: vec![0.0; nnz],
        }
    }
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
        self.new_symbolic = old_ptr != self.col_ptr || old_idx != self.row_idx;
        if self.new_symbolic {
            self.symbolic = None;
            self.permuted = None;
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
        // Sequential: the systems are small (a few thousand DOFs) and the machine shared;
        // packings solve their grains in parallel instead.
        let par = Par::Seq;
        if self.symbolic.is_none() {
            let n = 2 * self.n_nodes;
            let sym =
                SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
            let params = CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                ..Default::default()
            };
            let symbolic =
                factorize_symbolic_cholesky(sym, Side::Lower, SymmetricOrdering::Amd, params)
                    .map_err(|e| format!("{e:?}"))?;
            let supernodal = supernodal(&symbolic)?;
            self.factor.clear();
            self.factor.resize(symbolic.len_val(), 0.0);
            self.factor_mem = Some(MemBuffer::new(factorize_supernodal_numeric_llt_scratch::<
                usize,
                f64,
            >(
                supernodal, par, Default::default()
            )));
            self.solve_mem = None;
            self.solve_cols = 0;
            self.permuted = Some(Permuted::new(
                &self.col_ptr,
                &self.row_idx,
                &self.src,
                &symbolic,
            ));
            self.symbolic = Some(symbolic);
        }
        let (Some(symbolic), Some(fmem), Some(p)) =
            (&self.symbolic, &mut self.factor_mem, &mut self.permuted)
        else {
            return Err("no symbolic factorisation".into());
        };
        let supernodal = supernodal(symbolic)?;
        for (v, &s) in p.val.iter_mut().zip(&p.src) {
            *v = self.blocks[s / 4][((s % 4) / 2, s % 2)];
        }
        if fixed.iter().any(|&f| f) {
            // a fixed DOF's row and column reduced to the diagonal
            let ptr = p.pattern.col_ptr();
            for (c2, &c) in p.fwd.iter().enumerate() {
                for k in ptr[c2]..ptr[c2 + 1] {
                    let r = p.fwd[p.pattern.row_idx()[k]];
                    if r != c && (fixed[r] || fixed[c]) {
                        p.val[k] = 0.0;
                    }
                }
            }
        }
        self.factored = false;
        factorize_supernodal_numeric_llt::<usize, f64>(
            &mut self.factor,
            SparseColMatRef::new(p.pattern.as_ref(), &p.val),
            Default::default(),
            supernodal,
            par,
            MemStack::new(fmem),
            Default::default(),
        )
        .map_err(|e| format!("{e:?}"))?;
        self.factored = true;
        Ok(())
    }

    /// `out = Bᵀ K⁻¹ B` (`cols × cols`, column-major) for `cols` columns of `b` (column
    /// after column) with the last factorisation: with `K = Qᵀ L Lᵀ Q` (`Q` the
    /// fill-reducing order), `Y = L⁻¹ Q B` by the forward solve alone and `out = Yᵀ Y`, its
    /// lower half by one product, mirrored, so `out` is symmetric to the bit. Half the
    /// triangular work of `solve_factored`. `y` is scratch for `Y` (the caller's, so that
    /// the step allocates it once per thread, not per grain and iteration).
    pub fn inverse_gram(
        &mut self,
        b: &[f64],
        cols: usize,
        out: &mut [f64],
        y: &mut Vec<f64>,
    ) -> Result<(), String> {
        let n = 2 * self.n_nodes;
        let Some(symbolic) = self.symbolic.as_ref().filter(|_| self.factored) else {
            return Err("solve before factorisation".into());
        };
        if b.len() != n * cols || out.len() != cols * cols {
            return Err(format!(
                "{} and {} values for {cols} columns of {n}",
                b.len(),
                out.len()
            ));
        }
        let supernodal = supernodal(symbolic)?;
        let par = Par::Seq;
        y.clear();
        match symbolic.perm() {
            Some(perm) => {
                let fwd = perm.arrays().0;
                for col in b.chunks_exact(n) {
                    y.extend(fwd.iter().map(|&i| col[i]));
                }
            }
            None => y.extend_from_slice(b),
        }
        let mut y = faer::MatMut::from_column_major_slice_mut(y, n, cols);
        let smem = solve_stack(&mut self.solve_mem, &mut self.solve_cols, symbolic, cols);
        SupernodalLltRef::new(supernodal, &self.factor).l_solve_with_conj(
            Conj::No,
            y.as_mut(),
            par,
            MemStack::new(smem),
        );
        let mut w = faer::MatMut::from_column_major_slice_mut(out, cols, cols);
        triangular::matmul(
            w.as_mut(),
            BlockStructure::TriangularLower,
            Accum::Replace,
            y.as_ref().transpose(),
            BlockStructure::Rectangular,
            y.as_ref(),
            BlockStructure::Rectangular,
            1.0,
            par,
        );
        clear_upper_state();
        for j in 1..cols {
            for i in 0..j {
                w[(i, j)] = w[(j, i)];
            }
        }
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
        let smem = solve_stack(&mut self.solve_mem, &mut self.solve_cols, symbolic, cols);
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

    #[test]
    fn the_inverse_gram_is_b_transpose_times_the_solves() {
        // 6 × 6 grid of nodes, each coupled to its 8 neighbours: AMD reorders it and the
        // factor has several supernodes
        let side = 6;
        let nodes = side * side;
        let id = |x: usize, y: usize| y * side + x;
        let mut pairs = Vec::new();
        for y in 0..side {
            for x in 0..side {
                for (dx, dy) in [(1, 0), (0, 1), (1, 1)] {
                    if x + dx < side && y + dy < side {
                        pairs.push((id(x, y), id(x + dx, y + dy)));
                    }
                }
                if x > 0 && y + 1 < side {
                    let (a, b) = (id(x, y), id(x - 1, y + 1));
                    pairs.push((a.min(b), a.max(b)));
                }
            }
        }
        let springs = pairs.clone();
        let mut s = SymSystem::default();
        s.set_pattern(nodes, &mut pairs);
        let k = Matrix2::new(2.0, 0.5, 0.5, 1.0);
        for &(i, j) in &springs {
            s.add_block(s.lower_block(i, i), &k);
            s.add_block(s.lower_block(j, j), &k);
            s.add_block(s.lower_block(j, i), &(-k));
        }
        for i in 0..nodes {
            s.add_diag(i, 0.1 + 0.01 * i as f64);
        }
        s.factorize(&vec![false; 2 * nodes]).unwrap();
        let (n, cols) = (2 * nodes, 5);
        let b: Vec<f64> = (0..n * cols)
            .map(|k| {
                if k % 7 == 0 {
                    1.0 + (k % 5) as f64
                } else {
                    0.0
                }
            })
            .collect();
        let mut x = b.clone();
        s.solve_factored(&mut x, cols).unwrap();
        let mut gram = vec![0.0; cols * cols];
        s.inverse_gram(&b, cols, &mut gram, &mut Vec::new())
            .unwrap();
        for i in 0..cols {
            for j in 0..cols {
                let expected: f64 = (0..n).map(|r| b[i * n + r] * x[j * n + r]).sum();
                let got = gram[j * cols + i];
                assert!(
                    (got - expected).abs() < 1e-12 * expected.abs().max(1.0),
                    "{got} {expected}"
                );
                assert_eq!(got, gram[i * cols + j]);
            }
        }
    }
}
