//! Constants firmware and host must agree on, written once: the paper's measurement
//! grid, the USB identity the firmware enumerates with (and `gonio ports` looks for),
//! and the firmware version, taken from Cargo.

/// The paper's incidence angles theta_i (degrees): 0, 10, ..., 80.
pub const PAPER_INCIDENCES: [f32; 9] = [0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0];

/// The paper's detector angles theta_r (degrees, signed): -80, -70, ..., 80.
pub const PAPER_DETECTOR: [f32; 17] = [
    -80.0, -70.0, -60.0, -50.0, -40.0, -30.0, -20.0, -10.0, 0.0, 10.0, 20.0, 30.0, 40.0, 50.0,
    60.0, 70.0, 80.0,
];

/// Points of the paper grid (9 x 17).
pub const PAPER_POINTS: usize = PAPER_INCIDENCES.len() * PAPER_DETECTOR.len();

/// The `n`-th point of the paper grid as (theta_i, theta_r) in degrees: incidence-major,
/// detector angles ascending (`n` < [`PAPER_POINTS`]).
pub const fn paper_point(n: usize) -> (f32, f32) {
    (
        PAPER_INCIDENCES[n / PAPER_DETECTOR.len()],
        PAPER_DETECTOR[n % PAPER_DETECTOR.len()],
    )
}

/// USB vendor ID of the firmware (the shared V-USB/pid.codes range).
pub const USB_VID: u16 = 0x16c0;

/// USB product ID of the firmware (CDC-ACM).
pub const USB_PID: u16 = 0x27dd;

/// USB product string of the firmware; with the VID:PID shared by other hobby devices,
/// it is what identifies ours.
pub const USB_PRODUCT: &str = "gonio goniometer";

/// USB manufacturer string of the firmware.
pub const USB_MANUFACTURER: &str = "gonio";

/// The firmware version reported in the handshake (major, minor, patch): this crate's
/// version, which is the workspace's.
pub const FIRMWARE_VERSION: [u8; 3] = [
    decimal(env!("CARGO_PKG_VERSION_MAJOR")),
    decimal(env!("CARGO_PKG_VERSION_MINOR")),
    decimal(env!("CARGO_PKG_VERSION_PATCH")),
];

/// A small decimal number at compile time.
const fn decimal(s: &str) -> u8 {
    let b = s.as_bytes();
    let mut v: u32 = 0;
    let mut i = 0;
    while i < b.len() {
        assert!(b[i].is_ascii_digit(), "version part is not a number");
        v = v * 10 + (b[i] - b'0') as u32;
        assert!(v <= 255, "version part above 255");
        i += 1;
    }
    v as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_grid_is_9_by_17_incidence_major() {
        assert_eq!(PAPER_POINTS, 153);
        assert_eq!(paper_point(0), (0.0, -80.0));
        assert_eq!(paper_point(16), (0.0, 80.0));
        assert_eq!(paper_point(17), (10.0, -80.0));
        assert_eq!(paper_point(152), (80.0, 80.0));
        for (k, w) in PAPER_DETECTOR.windows(2).enumerate() {
            assert_eq!(w[1] - w[0], 10.0, "step at {k}");
        }
    }

    #[test]
    fn firmware_version_is_the_crate_version() {
        let [a, b, c] = FIRMWARE_VERSION;
        assert_eq!(format!("{a}.{b}.{c}"), env!("CARGO_PKG_VERSION"));
    }
}
