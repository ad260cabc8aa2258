//! Dense kernels on column-major buffers: faer's blocked (BLAS-3) products,
//! QR and symmetric eigensolver, always sequential (`Par::Seq`) so that the
//! results do not depend on the thread count, writing into caller-owned
//! buffers so that the large `n × d` blocks are allocated once per solve;
//! and the sparse product `L X` of blocks of columns.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::{Accum, Conj, Mat, MatMut, MatRef, Par};
use nalgebra::DMatrix;

use crate::solve::SparseMatrix;
use crate::{Error, Result};

/// The `n × c` column-major matrix stored in `buf[start·n .. (start + c)·n]`.
pub(super) fn fcols(buf: &[f64], n: usize, start: usize, c: usize) -> MatRef<'_, f64> {
    MatRef::from_column_major_slice(&buf[start * n..(start + c) * n], n, c)
}

/// Mutable version of [`fcols`].
pub(super) fn fcols_mut(buf: &mut [f64], n: usize, start: usize, c: usize) -> MatMut<'_, f64> {
    MatMut::from_column_major_slice_mut(&mut buf[start * n..(start + c) * n], n, c)
}

/// `dst = a · b` (`beta = Replace`) or `dst += a · b` (`Add`), times `alpha`.
pub(super) fn gemm(
    dst: MatMut<'_, f64>,
    beta: Accum,
    a: MatRef<'_, f64>,
    b: MatRef<'_, f64>,
    alpha: f64,
) {
    faer::linalg::matmul::matmul(dst, beta, a, b, alpha, Par::Seq);
}

/// A faer view of a whole nalgebra matrix.
pub(super) fn fview(m: &DMatrix<f64>) -> MatRef<'_, f64> {
    MatRef::from_column_major_slice(m.as_slice(), m.nrows(), m.ncols())
}

/// A mutable faer view of a whole nalgebra matrix.
pub(super) fn fview_mut(m: &mut DMatrix<f64>) -> MatMut<'_, f64> {
    let (r, c) = m.shape();
    MatMut::from_column_major_slice_mut(m.as_mut_slice(), r, c)
}

/// Householder QR of the `n × c` matrix `a` (`n ≥ c`, overwritten by the
/// factorisation): writes the thin `Q` into `q` and, if asked, `R` (`c × c`,
/// upper triangular) into `r`.
pub(super) fn thin_qr(
    mut a: MatMut<'_, f64>,
    mut q: MatMut<'_, f64>,
    r: Option<&mut DMatrix<f64>>,
) {
    use faer::linalg::{householder, qr::no_pivoting::factor};
    let (n, c) = (a.nrows(), a.ncols());
    if c == 0 {
        return;
    }
    let bs = factor::recommended_block_size::<f64>(n, c);
    let mut coeff = Mat::<f64>::zeros(bs, c);
    let req = StackReq::any_of(&[
        factor::qr_in_place_scratch::<f64>(n, c, bs, Par::Seq, Default::default()),
        householder::apply_block_householder_sequence_on_the_left_in_place_scratch::<f64>(n, bs, c),
    ]);
    let mut mem = MemBuffer::new(req);
    factor::qr_in_place(
        a.rb_mut(),
        coeff.as_mut(),
        Par::Seq,
        MemStack::new(&mut mem),
        Default::default(),
    );
    if let Some(r) = r {
        *r = DMatrix::from_fn(c, c, |i, j| if i <= j { a[(i, j)] } else { 0.0 });
    }
    q.fill(0.0);
    for j in 0..c {
        q[(j, j)] = 1.0;
    }
    householder::apply_block_householder_sequence_on_the_left_in_place_with_conj(
        a.rb(),
        coeff.as_ref(),
        Conj::No,
        q.rb_mut(),
        Par::Seq,
        MemStack::new(&mut mem),
    );
}

/// Eigen-decomposition of the symmetric `d × d` matrix `h` (lower triangle
/// read): (eigenvalues, eigenvectors), the eigenvalues ascending.
pub(super) fn sym_eigen(h: MatRef<'_, f64>) -> Result<(Vec<f64>, DMatrix<f64>)> {
    use faer::linalg::evd;
    let d = h.nrows();
    let mut s = Mat::<f64>::zeros(d, 1);
    let mut u = DMatrix::<f64>::zeros(d, d);
    let mut mem = MemBuffer::new(evd::self_adjoint_evd_scratch::<f64>(
        d,
        evd::ComputeEigenvectors::Yes,
        Par::Seq,
        Default::default(),
    ));
    evd::self_adjoint_evd(
        h,
        s.as_mut().col_mut(0).as_diagonal_mut(),
        Some(fview_mut(&mut u)),
        Par::Seq,
        MemStack::new(&mut mem),
        Default::default(),
    )
    .map_err(|e| Error::numerical(format!("dense symmetric eigensolver failed: {e:?}")))?;
    Ok(((0..d).map(|i| s[(i, 0)]).collect(), u))
}

/// `x ← (I − V Vᵀ) x` for the orthonormal columns `V` (`coef`: `d × c`
/// scratch).
pub(super) fn project_out(v: MatRef<'_, f64>, mut x: MatMut<'_, f64>, coef: &mut Mat<f64>) {
    if v.ncols() == 0 {
        return;
    }
    coef.resize_with(v.ncols(), x.ncols(), |_, _| 0.0);
    gemm(coef.as_mut(), Accum::Replace, v.transpose(), x.rb(), 1.0);
    gemm(x.rb_mut(), Accum::Add, v, coef.as_ref(), -1.0);
}

/// `out = L X` for the `c` columns of the column-major `x` (`L` sparse CSC,
/// `n × n`). Works on row-major copies of up to [`SPMM_CHUNK`] columns, so
/// that each stored entry of `L` updates a contiguous short row (the sums
/// are formed in the same order as column by column).
pub(super) fn sparse_times(l: &SparseMatrix, x: &[f64], out: &mut [f64], c: usize) {
    let n = l.nrows();
    let (offsets, rows, vals) = (l.col_offsets(), l.row_indices(), l.values());
    let width = c.min(SPMM_CHUNK);
    let mut xt = vec![0.0f64; n * width];
    let mut ot = vec![0.0f64; n * width];
    for j0 in (0..c).step_by(SPMM_CHUNK) {
        let w = (c - j0).min(SPMM_CHUNK);
        for jj in 0..w {
            let col = &x[(j0 + jj) * n..(j0 + jj + 1) * n];
            for (i, &v) in col.iter().enumerate() {
                xt[i * w + jj] = v;
            }
        }
        ot[..n * w].fill(0.0);
        for col in 0..n {
            let xc = &xt[col * w..(col + 1) * w];
            for e in offsets[col]..offsets[col + 1] {
                let (r, v) = (rows[e], vals[e]);
                for (o, &xv) in ot[r * w..(r + 1) * w].iter_mut().zip(xc) {
                    *o += v * xv;
                }
            }
        }
        for jj in 0..w {
            let col = &mut out[(j0 + jj) * n..(j0 + jj + 1) * n];
            for (i, o) in col.iter_mut().enumerate() {
                *o = ot[i * w + jj];
            }
        }
    }
}

/// Columns per pass of [`sparse_times`].
const SPMM_CHUNK: usize = 16;
