//! Dense LU factorisation with partial pivoting on reused buffers, bitwise equal to nalgebra's
//! (the linear solves of the continuation of docs/model.md §6.4).

use nalgebra::{DMatrix, DVector};

/// LU factorisation with partial pivoting, in place on a reused square matrix `a`: the operations
/// of nalgebra's `LU::new`, `solve` and `determinant` in the same order (pivot = the first entry
/// of largest modulus, multipliers scaled by the pivot's reciprocal, a zero pivot column skipped,
/// the same triangular solves), so the results are bitwise equal, without allocating.
pub(super) struct LuWork {
    pub(super) a: DMatrix<f64>,
    pub(super) swaps: Vec<(usize, usize)>,
}

impl LuWork {
    pub(super) fn new(d: usize) -> LuWork {
        LuWork { a: DMatrix::zeros(d, d), swaps: Vec::with_capacity(d) }
    }

    /// a = [j; borderᵀ] (j with one row fewer than a).
    pub(super) fn load_bordered(&mut self, j: &DMatrix<f64>, border: &DVector<f64>) {
        let d = self.a.nrows();
        for ((col, jc), b) in self.a.as_mut_slice().chunks_exact_mut(d).zip(j.as_slice().chunks_exact(d - 1)).zip(border.iter()) {
            col[..d - 1].copy_from_slice(jc);
            col[d - 1] = *b;
        }
    }

    /// Factorise `a` in place (L below the diagonal with a unit diagonal, U on and above it).
    pub(super) fn factor(&mut self) {
        let d = self.a.nrows();
        let a = self.a.as_mut_slice();
        // The sizes of the default five modes as constants (unrolled loops).
        match d {
            10 => lu_factor(a, 10, &mut self.swaps),
            11 => lu_factor(a, 11, &mut self.swaps),
            d => lu_factor(a, d, &mut self.swaps),
        }
    }

    /// Determinant of the factorised matrix.
    pub(super) fn determinant(&self) -> f64 {
        let mut det = 1.0;
        for i in 0..self.a.nrows() {
            det *= self.a[(i, i)];
        }
        det * if self.swaps.len().is_multiple_of(2) { 1.0 } else { -1.0 }
    }

    /// Solve with the factorised matrix, b overwritten by the solution; false on a zero pivot.
    pub(super) fn solve(&self, b: &mut DVector<f64>) -> bool {
        for &(i, p) in &self.swaps {
            b.swap_rows(i, p);
        }
        let (a, b) = (self.a.as_slice(), b.as_mut_slice());
        match self.a.nrows() {
            10 => lu_solve(a, 10, b),
            11 => lu_solve(a, 11, b),
            d => lu_solve(a, d, b),
        }
    }

    pub(super) fn factor_solve(&mut self, b: &mut DVector<f64>) -> bool {
        self.factor();
        self.solve(b)
    }
}

/// out = a·x for the n×n column-major `a`, summed as nalgebra's matrix–vector product (column
/// by column: out = a₀x₀, then out += aⱼxⱼ), so bitwise equal to it.
#[inline(always)]
pub(super) fn matvec(a: &[f64], x: &[f64], out: &mut [f64], n: usize) {
    let (a, x, out) = (&a[..n * n], &x[..n], &mut out[..n]);
    for (o, aij) in out.iter_mut().zip(&a[..n]) {
        *o = aij * x[0];
    }
    for (col, xj) in a.chunks_exact(n).zip(x).skip(1) {
        for (o, aij) in out.iter_mut().zip(col) {
            *o += aij * xj;
        }
    }
}

/// Body of [`LuWork::factor`] on the column-major d×d `a` ((r, c) at c·d + r).
#[inline(always)]
pub(super) fn lu_factor(a: &mut [f64], d: usize, swaps: &mut Vec<(usize, usize)>) {
    let a = &mut a[..d * d];
    swaps.clear();
    for i in 0..d {
        let col = &a[i * d..(i + 1) * d];
        let (mut piv, mut max) = (i, col[i].abs());
        for (r, x) in col.iter().enumerate().skip(i + 1) {
            if x.abs() > max {
                (piv, max) = (r, x.abs());
            }
        }
        let diag = col[piv];
        if diag == 0.0 {
            continue;
        }
        if piv != i {
            swaps.push((i, piv));
            for c in 0..d {
                a.swap(c * d + i, c * d + piv);
            }
        }
        let inv_diag = 1.0 / diag;
        for x in &mut a[i * d + i + 1..(i + 1) * d] {
            *x *= inv_diag;
        }
        let (left, right) = a.split_at_mut((i + 1) * d);
        let coeffs = &left[i * d + i + 1..];
        for col in right.chunks_exact_mut(d) {
            let p = col[i];
            for (y, l) in col[i + 1..].iter_mut().zip(coeffs) {
                *y += -p * l;
            }
        }
    }
}

/// Triangular solves of [`LuWork::solve`] (rows of b already permuted).
#[inline(always)]
pub(super) fn lu_solve(a: &[f64], d: usize, b: &mut [f64]) -> bool {
    let (a, b) = (&a[..d * d], &mut b[..d]);
    for i in 0..d - 1 {
        let coeff = b[i];
        for (y, l) in b[i + 1..].iter_mut().zip(&a[i * d + i + 1..(i + 1) * d]) {
            *y += -coeff * l;
        }
    }
    for i in (0..d).rev() {
        let diag = a[i * d + i];
        if diag == 0.0 {
            return false;
        }
        let coeff = b[i] / diag;
        b[i] = coeff;
        for (y, u) in b[..i].iter_mut().zip(&a[i * d..i * d + i]) {
            *y += -coeff * u;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;
    #[test]
    fn lu_work_and_matvec_are_bitwise_nalgebra() {
        // Pseudo-random matrices of the sizes in use (10, 11) and others, some singular (a zero
        // column, a repeated row): factors, determinant and solution equal nalgebra's LU bit for
        // bit, and `matvec` equals nalgebra's matrix–vector product.
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let bits = |m: &[f64]| m.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for d in [1, 2, 3, 5, 7, 10, 11, 12, 21] {
            for case in 0..12 {
                let mut m = DMatrix::from_fn(d, d, |_, _| rnd());
                if d > 1 && case == 1 {
                    m.column_mut(d / 2).fill(0.0);
                }
                if d > 1 && case == 2 {
                    let r = m.row(0).into_owned();
                    m.row_mut(d - 1).copy_from(&r);
                }
                let b = DVector::from_fn(d, |_, _| rnd());
                let reference = m.clone().lu();
                let mut lu = LuWork::new(d);
                lu.a.copy_from(&m);
                lu.factor();
                let mut l = lu.a.lower_triangle();
                l.fill_diagonal(1.0);
                assert_eq!(bits(l.as_slice()), bits(reference.l().as_slice()), "L, d = {d}, case {case}");
                assert_eq!(bits(lu.a.upper_triangle().as_slice()), bits(reference.u().as_slice()), "U, d = {d}, case {case}");
                assert_eq!(lu.determinant().to_bits(), reference.determinant().to_bits(), "det, d = {d}, case {case}");
                let mut x = b.clone();
                let solved = lu.solve(&mut x);
                match reference.solve(&b) {
                    Some(xr) => assert!(solved && bits(x.as_slice()) == bits(xr.as_slice()), "solve, d = {d}, case {case}"),
                    None => assert!(!solved, "solve, d = {d}, case {case}"),
                }
                let mut y = DVector::zeros(d);
                matvec(m.as_slice(), b.as_slice(), y.as_mut_slice(), d);
                assert_eq!(bits(y.as_slice()), bits((&m * &b).as_slice()), "matvec, d = {d}, case {case}");
            }
        }
    }
}
