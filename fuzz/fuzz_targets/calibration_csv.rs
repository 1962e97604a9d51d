//! The calibration log reader on arbitrary text: never a panic, and an accepted log is
//! uniformly sampled with finite values and at least 100 samples.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(log) = beam_log::read_log(text, "fuzz.csv") {
        assert!(log.t.len() >= 100);
        assert!(log.torque.iter().chain(&log.theta).all(|v| v.is_finite()));
        assert!(log.t.windows(2).all(|w| w[1] > w[0]));
    }
});
