//! Information criteria of a least-squares fit: AICc and BIC from its sum of squares.

/// BIC from the sum of squares `ssr` of `n` readings and `k` free parameters.
pub fn bic(ssr: f64, n: usize, k: usize) -> f64 {
    let (n, k) = (n as f64, k as f64);
    n * (ssr / n).max(1e-300).ln() + k * n.ln()
}

/// AICc (Akaike's criterion with the small-sample correction) from the sum of squares
/// `ssr` of `n` readings and `k` free parameters; infinite when n <= k + 1.
pub fn aicc(ssr: f64, n: usize, k: usize) -> f64 {
    let (n, k) = (n as f64, k as f64);
    if n <= k + 1.0 {
        return f64::INFINITY;
    }
    n * (ssr / n).max(1e-300).ln() + 2.0 * k + 2.0 * k * (k + 1.0) / (n - k - 1.0)
}
