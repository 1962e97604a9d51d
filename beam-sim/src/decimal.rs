//! Numbers as the decimals they stand for: an `f32` gain or sample period read back as its
//! shortest decimal, and tick times computed so they print as the decimals they are.

/// An `f32` as the `f64` of its shortest decimal form: 0.1f32 becomes 0.1, not
/// 0.10000000149011612, so gains print and round-trip through files as they were written.
pub fn f32_decimal(x: f32) -> f64 {
    x.to_string().parse::<f64>().unwrap_or(x as f64)
}

/// The time of tick `k` at period `ts_s`, as the decimal it is: `k / rate` is the nearest
/// double to that decimal when the rate is a whole number of hertz (`k * 0.001` is not:
/// 572 * 0.001 = 0.5720000000000001).
pub fn tick_time(k: usize, ts_s: f64) -> f64 {
    let rate = (1.0 / ts_s).round();
    if (rate * ts_s - 1.0).abs() < 1e-12 {
        k as f64 / rate
    } else {
        k as f64 * ts_s
    }
}
