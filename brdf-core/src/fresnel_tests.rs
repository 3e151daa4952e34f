//! The Fresnel reflectance against the Fresnel equations in complex arithmetic, its
//! closed forms (normal incidence, grazing, Brewster's angle), and the metal table.

use super::*;

/// A complex number, only for the independent reference below.
#[derive(Debug, Clone, Copy)]
struct C(f64, f64);

impl C {
    fn add(self, o: C) -> C {
        C(self.0 + o.0, self.1 + o.1)
    }
    fn sub(self, o: C) -> C {
        C(self.0 - o.0, self.1 - o.1)
    }
    fn mul(self, o: C) -> C {
        C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
    }
    fn abs2(self) -> f64 {
        self.0 * self.0 + self.1 * self.1
    }
    /// Principal square root (real part >= 0).
    fn sqrt(self) -> C {
        let r = self.abs2().sqrt();
        let re = ((r + self.0) / 2.0).max(0.0).sqrt();
        let im = ((r - self.0) / 2.0).max(0.0).sqrt();
        C(re, if self.1 < 0.0 { -im } else { im })
    }
}

/// The Fresnel equations for the amplitudes, eta = n + ik from air:
/// u = eta cos(theta_t) = sqrt(eta^2 - sin^2), r_s = (c - u) / (c + u),
/// r_p = (eta^2 c - u) / (eta^2 c + u); F = (|r_s|^2 + |r_p|^2) / 2.
fn reference(c: f64, n: f64, k: f64) -> f64 {
    let eta2 = C(n, k).mul(C(n, k));
    let u = eta2.sub(C(1.0 - c * c, 0.0)).sqrt();
    let cc = C(c, 0.0);
    let rs = cc.sub(u).abs2() / cc.add(u).abs2();
    let e2c = eta2.mul(cc);
    let rp = e2c.sub(u).abs2() / e2c.add(u).abs2();
    (rs + rp) / 2.0
}

const INDICES: [(f64, f64); 8] = [
    (1.5, 0.0),
    (2.4, 0.0),
    (0.7, 0.0),
    (0.9, 6.4),
    (2.9, 2.9),
    (0.05, 3.4),
    (1.02, 2.58),
    (0.3, 0.01),
];

#[test]
fn agrees_with_the_fresnel_equations_in_complex_arithmetic() {
    for (n, k) in INDICES {
        for d in 0..=900 {
            let theta = (d as f64 / 10.0).to_radians();
            let c = theta.cos();
            let (got, want) = (reflectance(c, n, k), reference(c, n, k));
            assert!(
                (got - want).abs() <= 1e-12,
                "n {n} k {k} theta {}: {got} vs {want}",
                d as f64 / 10.0
            );
            assert!((0.0..=1.0).contains(&got), "n {n} k {k}: {got}");
            let got32 = reflectance(c as f32, n as f32, k as f32);
            assert!(
                (got32 as f64 - want).abs() <= 2e-5,
                "f32 n {n} k {k}: {got32} vs {want}"
            );
        }
    }
}

#[test]
fn normal_incidence_grazing_and_brewster() {
    for (n, k) in INDICES {
        let f0 = ((n - 1.0) * (n - 1.0) + k * k) / ((n + 1.0) * (n + 1.0) + k * k);
        // The general form reaches the closed one to round-off.
        assert!((reflectance(1.0, n, k) - f0).abs() < 1e-14, "n {n} k {k}");
        assert_eq!(normal_reflectance(n, k), f0);
        assert_eq!(reflectance(0.0, n, k), 1.0, "grazing, n {n} k {k}");
        assert!(reflectance(1e-4, n, k) > 0.99, "near grazing, n {n} k {k}");
        // Beyond normal incidence a conductor or denser dielectric first dips (p
        // polarisation) or rises, but never leaves [0, 1].
    }
    // A dielectric's p reflectance vanishes at Brewster's angle, tan = n: F = R_s / 2.
    for n in [1.33f64, 1.5, 2.4] {
        let c = n.atan().cos();
        let s2 = 1.0 - c * c;
        let a = (n * n - s2).sqrt();
        let rs = ((c - a) / (c + a)).powi(2);
        assert!((reflectance(c, n, 0.0) - rs / 2.0).abs() < 1e-14, "n {n}");
    }
    // No interface, no reflection (except at exactly grazing incidence).
    assert!(reflectance(0.5, 1.0, 0.0) < 1e-15);
    // Total internal reflection in a rarer medium (n < 1) beyond its critical angle.
    let c = (1.0 - 0.7f64 * 0.7).sqrt() * 0.99;
    assert!((reflectance(c, 0.7, 0.0) - 1.0).abs() < 1e-12);
}

#[test]
fn the_metal_table_reads_its_rows_and_interpolates_between() {
    for m in &METALS {
        assert!(m.rows.windows(2).all(|w| w[0].0 < w[1].0), "{}", m.name);
        assert!(m.rows[0].0 <= 451.0 && m.rows[m.rows.len() - 1].0 >= 1064.0);
        for &(nm, n, k) in m.rows {
            assert_eq!(m.at(nm), Ok(Index { n, k }), "{} at {nm}", m.name);
        }
    }
    // al@532 lies between Rakic's rows at 516.60 and 563.57 nm.
    let (m, i) = metal("al@532").unwrap();
    assert_eq!(m.name, "al");
    let t = (532.0 - 516.60) / (563.57 - 516.60);
    assert!((i.n - (0.8734 + t * (1.0728 - 0.8734))).abs() < 1e-12);
    assert!((i.k - (6.2418 + t * (6.7839 - 6.2418))).abs() < 1e-12);
    assert!(metal("Au@633").is_ok() && metal(" fe @ 1064 ").is_ok());
    assert_eq!(metal("al532").unwrap_err(), MetalError::Syntax);
    assert_eq!(metal("al@green").unwrap_err(), MetalError::Syntax);
    assert_eq!(metal("pb@532").unwrap_err(), MetalError::Unknown);
    assert_eq!(
        metal("ag@300").unwrap_err(),
        MetalError::OutOfRange(450.9, 1088.0)
    );
    // At 532 nm silver reflects more than aluminium, aluminium more than iron; gold
    // and copper reflect more in the red than in the green (their interband
    // absorption edge lies between).
    let f0 = |s: &str| {
        let (_, i) = metal(s).unwrap();
        normal_reflectance(i.n, i.k)
    };
    assert!(f0("ag@532") > f0("al@532") && f0("al@532") > f0("fe@532"));
    assert!(f0("au@633") > f0("au@532") && f0("cu@633") > f0("cu@532"));
}

#[test]
fn gradient_matches_the_value_and_central_differences() {
    // Conductors (Al, Cu, Fe at 532 nm), dielectrics (n = 1.5, n = 0.7 past its
    // critical angle), at normal, oblique and near-grazing angles.
    for &(n, k) in &[
        (0.9f64, 6.4f64),
        (1.1, 2.6),
        (2.9, 2.9),
        (1.5, 0.0),
        (0.7, 0.0),
        (4.0, 0.3),
    ] {
        for &c in &[1.0f64, 0.9, 0.5, 0.2, 0.05, 0.01] {
            let (f, dn, dk) = reflectance_with_gradient(c, n, k);
            assert_eq!(f, reflectance(c, n, k), "n={n} k={k} c={c}");
            let h = 1e-6;
            let num_n = (reflectance(c, n + h, k) - reflectance(c, n - h, k)) / (2.0 * h);
            assert!(
                (dn - num_n).abs() <= 1e-6 * (1.0 + num_n.abs()),
                "dF/dn n={n} k={k} c={c}: {dn} vs {num_n}"
            );
            if k > 0.0 {
                let num_k = (reflectance(c, n, k + h) - reflectance(c, n, k - h)) / (2.0 * h);
                assert!(
                    (dk - num_k).abs() <= 1e-6 * (1.0 + num_k.abs()),
                    "dF/dk n={n} k={k} c={c}: {dk} vs {num_k}"
                );
            } else {
                // At k = 0 F is even in k: its derivative there is 0.
                assert_eq!(dk, 0.0);
            }
        }
    }
    // f32 agrees with f64.
    let (f, dn, dk) = reflectance_with_gradient(0.5f32, 0.9, 6.4);
    let (g, en, ek) = reflectance_with_gradient(0.5f64, 0.9, 6.4);
    assert!(
        (f as f64 - g).abs() < 1e-5
            && (dn as f64 - en).abs() < 1e-4
            && (dk as f64 - ek).abs() < 1e-4
    );
}
