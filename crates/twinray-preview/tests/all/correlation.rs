//! What an anaglyph's channels follow: Pearson's correlation of one
//! channel of an image with the luma of another, both as RGB triplets
//! (shared with the browser test).

/// The correlation of channel `channel` of `a` with the luma of `b`.
pub fn correlation(a: &[f64], channel: usize, b: &[f64]) -> f64 {
    let (mut sx, mut sy, mut sxy, mut sxx, mut syy, mut n) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (p, q) in a.chunks(3).zip(b.chunks(3)) {
        let x = p[channel];
        let y = 0.3 * q[0] + 0.6 * q[1] + 0.1 * q[2];
        sx += x;
        sy += y;
        sxy += x * y;
        sxx += x * x;
        syy += y * y;
        n += 1.0;
    }
    let cov = sxy / n - sx * sy / (n * n);
    cov / ((sxx / n - (sx / n).powi(2)) * (syy / n - (sy / n).powi(2))).sqrt()
}
