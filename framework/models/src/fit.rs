//! Least-squares polynomial fits (the thesis' Matlab curve-fitting step, section 3.3.2).

use nalgebra::{DMatrix, DVector};

/// Why a fit failed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FitError {
    /// Fewer samples than coefficients.
    TooFewSamples {
        /// Samples given.
        samples: usize,
        /// Coefficients asked for.
        coefficients: usize,
    },
    /// The samples do not determine the coefficients (e.g. all at one deflection).
    Singular,
}

impl std::fmt::Display for FitError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FitError::TooFewSamples { samples, coefficients } => {
                write!(f, "{samples} samples cannot determine {coefficients} coefficients")
            }
            FitError::Singular => f.write_str("the samples do not determine the polynomial (too little spread in deflection)"),
        }
    }
}

impl std::error::Error for FitError {}

/// Fits `y = sum_{k=first..=order} c_k x^k` by least squares (SVD), returning `[c_first, ..]`.
fn fit_powers(x: &[f64], y: &[f64], first: usize, order: usize) -> Result<Vec<f64>, FitError> {
    let m = order + 1 - first;
    if x.len() < m {
        return Err(FitError::TooFewSamples { samples: x.len(), coefficients: m });
    }
    let a = DMatrix::from_fn(x.len(), m, |i, j| x[i].powi((first + j) as i32));
    let b = DVector::from_column_slice(y);
    let svd = a.svd(true, true);
    let max_sv = svd.singular_values.max();
    if max_sv <= 0.0 || svd.singular_values.min() <= max_sv * 1e-12 {
        return Err(FitError::Singular);
    }
    let c = svd.solve(&b, max_sv * 1e-12).map_err(|_| FitError::Singular)?;
    Ok(c.iter().copied().collect())
}

/// Fits a polynomial through zero, `y = c1 x + ... + cn x^n`; returns `[c1, .., cn]`.
///
/// ```
/// let x: Vec<f64> = (0..50).map(|i| i as f64 / 50.0 - 0.5).collect();
/// let y: Vec<f64> = x.iter().map(|x| 3.0 * x - 2.0 * x * x * x).collect();
/// let c = jointctl_models::fit::through_zero(&x, &y, 3).unwrap();
/// assert!((c[0] - 3.0).abs() < 1e-9 && c[1].abs() < 1e-9 && (c[2] + 2.0).abs() < 1e-9);
/// ```
pub fn through_zero(x: &[f64], y: &[f64], order: usize) -> Result<Vec<f64>, FitError> {
    fit_powers(x, y, 1, order)
}

/// Fits a polynomial with a constant term, `y = c0 + c1 x + ... + cn x^n`; returns `[c0, .., cn]`.
pub fn polynomial(x: &[f64], y: &[f64], order: usize) -> Result<Vec<f64>, FitError> {
    fit_powers(x, y, 0, order)
}

/// Root-mean-square of `a - b`.
pub fn rmse(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len()).max(1);
    (a.iter().zip(b).map(|(p, q)| (p - q) * (p - q)).sum::<f64>() / n as f64).sqrt()
}
