//! Least squares for the design: a block-wise Householder QR on unit-norm columns, the same
//! fit per segment, and the dot products under them. A leaf: it knows nothing of causes or
//! models.

use nalgebra::{DMatrix, DVector};

pub(crate) fn dot_row(cols: &[Vec<f64>], coefs: &[f64], i: usize) -> f64 {
    cols.iter().zip(coefs).map(|(c, k)| c[i] * k).sum()
}

/// Least squares by Householder QR on unit-norm columns (their scales differ by orders of
/// magnitude: a cubic in radians next to a constant); `None` when a column is (numerically) a
/// combination of the others. An all-zero column gets a zero coefficient.
///
/// The QR runs block by block over the rows (tall-skinny QR: the triangle so far stacked on the
/// next [`ROWS_PER_BLOCK`] rows, with `y` as one more column), so the n x k matrix is never built
/// and every block stays in the cache: the same factor R as a QR of the whole matrix (up to
/// signs), at a fraction of the memory traffic.
pub(crate) fn least_squares(cols: &[Vec<f64>], y: &[f64]) -> Option<Vec<f64>> {
    let n = y.len();
    let scale: Vec<f64> = cols.iter().map(|c| dot(c, c).sqrt()).collect();
    let live: Vec<usize> = (0..cols.len()).filter(|j| scale[*j] > 0.0 && scale[*j].is_finite()).collect();
    let mut out = vec![0.0; cols.len()];
    if live.is_empty() {
        return Some(out);
    }
    let m = live.len();
    if n < m {
        return None;
    }
    let r = triangle(cols, &live, &scale, y);
    let w = m + 1;
    let biggest = (0..m).map(|j| r[j * w + j].abs()).fold(0.0, f64::max);
    if (0..m).any(|j| r[j * w + j].abs() <= 1e-10 * biggest) {
        return None;
    }
    // Back substitution: R x = Q^T y (the last column of the augmented triangle).
    let mut x = vec![0.0; m];
    for j in (0..m).rev() {
        let tail: f64 = (j + 1..m).map(|c| r[j * w + c] * x[c]).sum();
        x[j] = (r[j * w + m] - tail) / r[j * w + j];
    }
    for (k, j) in live.iter().enumerate() {
        out[*j] = x[k] / scale[*j];
    }
    out.iter().all(|c| c.is_finite()).then_some(out)
}

/// The variance a fit's residual charges its parameters' errors with [Nm^2]: `s^2 = RSS / (n -
/// k)` for `parameters` = k, inflated for the residual's lag-1 autocorrelation `rho` (clamped to
/// 0..0.99) by `(1 + rho) / (1 - rho)`, the AR(1) variance factor of a mean. Shared by the
/// coefficients' standard errors (`design::Model::standard_errors`) and the causes' parameter
/// errors (`uncertainty`).
pub(crate) fn ar1_inflated_variance(residual: &[f64], parameters: usize) -> f64 {
    let rss = dot(residual, residual);
    let rho = (residual.windows(2).map(|w| w[0] * w[1]).sum::<f64>() / rss.max(1e-300)).clamp(0.0, 0.99);
    rss / residual.len().saturating_sub(parameters).max(1) as f64 * (1.0 + rho) / (1.0 - rho)
}

/// The dot product of two equally long slices, summed in four lanes (a single running sum
/// waits on every addition; four let the processor pipeline and vectorise them).
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut lanes = [0.0; 4];
    let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = a4.remainder().iter().zip(b4.remainder()).map(|(x, y)| x * y).sum();
    for (x, y) in a4.zip(b4) {
        for k in 0..4 {
            lanes[k] += x[k] * y[k];
        }
    }
    (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]) + tail
}

/// Rows stacked under the triangle per Householder step of [`least_squares`] (a block of
/// 128 x 9 values is 9 KiB: it stays in the first-level cache).
const ROWS_PER_BLOCK: usize = 128;

/// The upper triangle R (row-major, (k+1) x (k+1)) of the QR of [columns / scale | y].
fn triangle(cols: &[Vec<f64>], live: &[usize], scale: &[f64], y: &[f64]) -> Vec<f64> {
    let (n, m) = (y.len(), live.len());
    let w = m + 1;
    let mut r = vec![0.0; w * w];
    // The block, column-major: block[c * ROWS_PER_BLOCK + i].
    let mut block = vec![0.0; w * ROWS_PER_BLOCK];
    let mut v = [0.0; ROWS_PER_BLOCK];
    let mut from = 0;
    while from < n {
        let rows = (n - from).min(ROWS_PER_BLOCK);
        for (c, j) in live.iter().enumerate() {
            let (col, s) = (&cols[*j][from..from + rows], scale[*j]);
            for (b, x) in block[c * ROWS_PER_BLOCK..c * ROWS_PER_BLOCK + rows].iter_mut().zip(col) {
                *b = x / s;
            }
        }
        block[m * ROWS_PER_BLOCK..m * ROWS_PER_BLOCK + rows].copy_from_slice(&y[from..from + rows]);
        for j in 0..w {
            // The reflection that folds column j of the block into R[j][j].
            let x = &block[j * ROWS_PER_BLOCK..j * ROWS_PER_BLOCK + rows];
            let sigma = dot(x, x);
            if sigma == 0.0 {
                continue;
            }
            let alpha = r[j * w + j];
            let norm = (alpha * alpha + sigma).sqrt();
            let beta = if alpha > 0.0 { -norm } else { norm };
            let inv = 1.0 / (alpha - beta);
            for (vi, xi) in v.iter_mut().zip(x) {
                *vi = xi * inv;
            }
            let tau = (beta - alpha) / beta;
            r[j * w + j] = beta;
            for c in j + 1..w {
                let bc = &mut block[c * ROWS_PER_BLOCK..c * ROWS_PER_BLOCK + rows];
                let s = tau * (r[j * w + c] + dot(&v[..rows], bc));
                r[j * w + c] -= s;
                for (b, vi) in bc.iter_mut().zip(&v[..rows]) {
                    *b -= s * vi;
                }
            }
        }
        from += rows;
    }
    r
}

/// Fits `cols` to `r` anew on every segment: the fitted values, every segment's coefficients
/// (segment after segment) and, when asked, each sample's leverage. Normal equations per segment are fine
/// here: a segment's two ring columns are near-orthogonal (sine and cosine under one envelope).
pub(crate) fn fit_segments(cols: &[Vec<f64>], starts: &[usize], r: &[f64], want_leverage: bool) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = r.len();
    let k = cols.len();
    let mut fitted = vec![0.0; n];
    let mut leverage = vec![0.0; n];
    let mut coefs = Vec::with_capacity(starts.len() * k);
    let mut gram = DMatrix::<f64>::zeros(k, k);
    let mut rhs = DVector::<f64>::zeros(k);
    let mut x = DVector::<f64>::zeros(k);
    for (s, &a) in starts.iter().enumerate() {
        let b = starts.get(s + 1).copied().unwrap_or(n).min(n);
        gram.fill(0.0);
        rhs.fill(0.0);
        for i in a..b.max(a) {
            for p in 0..k {
                rhs[p] += cols[p][i] * r[i];
                for q in 0..=p {
                    gram[(p, q)] += cols[p][i] * cols[q][i];
                }
            }
        }
        for p in 0..k {
            for q in 0..p {
                gram[(q, p)] = gram[(p, q)];
            }
        }
        let Some(chol) = (a < b).then(|| gram.clone().cholesky()).flatten() else {
            coefs.extend(std::iter::repeat_n(0.0, k));
            continue;
        };
        let c = chol.solve(&rhs);
        let inv = if want_leverage { chol.inverse() } else { DMatrix::zeros(k, k) };
        for i in a..b {
            for p in 0..k {
                x[p] = cols[p][i];
            }
            fitted[i] = x.dot(&c);
            if want_leverage {
                leverage[i] = (&inv * &x).dot(&x);
            }
        }
        coefs.extend(c.iter());
    }
    (fitted, coefs, leverage)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A design whose columns differ in scale by six orders of magnitude, 1000 rows (not a
    /// multiple of the block), solved by an SVD of the whole matrix for comparison.
    fn design(rows: usize) -> (Vec<Vec<f64>>, Vec<f64>) {
        let mut rng = jointctl_test_support::XorShift64::new(7);
        let x: Vec<f64> = (0..rows).map(|_| rng.uniform() * 0.2 - 0.1).collect();
        let cols = vec![x.clone(), x.iter().map(|v| v.powi(3)).collect(), vec![1.0; rows], x.iter().map(|v| (40.0 * v).sin()).collect()];
        let y = (0..rows).map(|i| 120.0 * cols[0][i] - 30.0 * cols[1][i] + 0.4 * cols[2][i] + 0.05 * cols[3][i] + 0.01 * (rng.uniform() - 0.5)).collect();
        (cols, y)
    }

    #[test]
    fn blockwise_qr_solves_as_a_whole_matrix_svd_does() {
        for rows in [5, 127, 128, 129, 1000] {
            let (cols, y) = design(rows);
            let a = DMatrix::from_fn(rows, cols.len(), |i, j| cols[j][i]);
            let expected = a.svd(true, true).solve(&DVector::from_column_slice(&y), 1e-14).unwrap();
            let got = least_squares(&cols, &y).unwrap();
            for (g, e) in got.iter().zip(expected.iter()) {
                assert!((g - e).abs() <= 1e-8 * e.abs().max(1.0), "{rows} rows: {got:?} vs {expected:?}");
            }
        }
    }

    #[test]
    fn a_column_that_repeats_others_is_refused_and_a_zero_column_gets_zero() {
        let (mut cols, y) = design(300);
        let combination: Vec<f64> = (0..300).map(|i| 2.0 * cols[0][i] - cols[2][i]).collect();
        cols.push(combination);
        assert!(least_squares(&cols, &y).is_none());
        cols.pop();
        cols.push(vec![0.0; 300]);
        let got = least_squares(&cols, &y).unwrap();
        assert_eq!(got[4], 0.0);
        assert!((got[0] - 120.0).abs() < 0.1, "{got:?}");
        // Fewer rows than columns: no fit.
        let short: Vec<Vec<f64>> = cols.iter().map(|c| c[..3].to_vec()).collect();
        assert!(least_squares(&short[..4], &y[..3]).is_none());
    }
}
