//! Tests of the RGL reader: the committed real material against an independent
//! evaluation (tests/data/rgl_reference.py, plain Python from the reference reader),
//! a hand-made tensor whose value is derived by hand, and damaged files.

use std::collections::BTreeMap;

use super::super::tensor::read_tensor;
use super::*;

fn real() -> RglBrdf {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/rgl_ilm_l3_37_metallic_rgb.bsdf");
    RglBrdf::from_fields(&read_tensor(&std::fs::read(path).unwrap()).unwrap()).unwrap()
}

/// (theta_i, theta_r, f_r of R, G, B, Y) printed by rgl_reference.py (see
/// tests/data/README.md): on the mirror, off it, between measured incidences (33), at
/// grazing exit.
const REFERENCE: [(f64, f64, [f64; 4]); 12] = [
    (
        0.0,
        0.0,
        [
            77.80634788004683,
            79.05331352644134,
            78.02917051804252,
            78.71426550481148,
        ],
    ),
    (
        0.0,
        -45.0,
        [
            0.03165852938303092,
            0.03292278919180226,
            0.03308303642727294,
            0.03266557740685846,
        ],
    ),
    (
        20.0,
        20.0,
        [
            71.08244648121196,
            72.0614879833187,
            71.61149423724135,
            71.82085421150401,
        ],
    ),
    (
        20.0,
        19.5,
        [
            63.77958901293596,
            64.72360915251467,
            64.15781366215649,
            64.48206003643637,
        ],
    ),
    (
        20.0,
        -60.0,
        [
            0.0044373442161456875,
            0.0045988137576509335,
            0.00461570126365051,
            0.004565704611060087,
        ],
    ),
    (
        40.0,
        41.0,
        [
            61.290444291037865,
            62.40937694655812,
            62.314822023687675,
            62.16466499856327,
        ],
    ),
    (
        40.0,
        10.0,
        [
            0.1405354106512458,
            0.14415524362421808,
            0.1428980582466581,
            0.14329489834990433,
        ],
    ),
    (
        60.0,
        60.0,
        [
            168.9085704010242,
            170.08052920095056,
            169.58281408924725,
            169.79543572902125,
        ],
    ),
    (
        60.0,
        -30.0,
        [
            0.002308865729092664,
            0.0023850702083008275,
            0.002363477206477951,
            0.00236731012128956,
        ],
    ),
    (
        75.0,
        80.0,
        [
            22.467162150989722,
            22.622937888598326,
            22.414995169029332,
            22.574806502429855,
        ],
    ),
    (
        33.0,
        -89.0,
        [
            0.004522207152828202,
            0.004682155465372778,
            0.004692956494679561,
            0.00464893028844175,
        ],
    ),
    (
        0.0,
        89.0,
        [
            0.08605521351106057,
            0.08828441846081797,
            0.08727814695624031,
            0.08773783668586903,
        ],
    ),
];

#[test]
fn the_real_material_matches_an_independent_evaluation() {
    let m = real();
    assert_eq!(m.theta_i.len(), 8);
    assert!(
        m.description.starts_with("Metallic paint from L3-37"),
        "{}",
        m.description
    );
    for (ti, tr, want) in REFERENCE {
        for (c, w) in [RglChannel::R, RglChannel::G, RglChannel::B, RglChannel::Y]
            .into_iter()
            .zip(want)
        {
            let got = m.in_plane(c, ti, tr);
            assert!(
                (got - w).abs() <= 1e-9 * w,
                "{ti} {tr} {}: {got} vs {w}",
                c.name()
            );
        }
    }
    // Below the horizon: nothing.
    assert_eq!(m.in_plane(RglChannel::Y, 20.0, 90.0), 0.0);
}

/// Bytes of a tensor file holding `fields` (name, shape, f32 values).
fn tensor_bytes(fields: &[(&str, Vec<u64>, Vec<f32>)]) -> Vec<u8> {
    let mut head = b"tensor_file\0\x01\x00".to_vec();
    head.extend((fields.len() as u32).to_le_bytes());
    let header_len: usize = head.len()
        + fields
            .iter()
            .map(|(n, s, _)| 2 + n.len() + 2 + 1 + 8 + 8 * s.len())
            .sum::<usize>();
    let mut data = Vec::new();
    for (name, shape, values) in fields {
        head.extend((name.len() as u16).to_le_bytes());
        head.extend(name.as_bytes());
        head.extend((shape.len() as u16).to_le_bytes());
        head.push(10);
        head.extend(((header_len + data.len()) as u64).to_le_bytes());
        for s in shape {
            head.extend(s.to_le_bytes());
        }
        for v in values {
            data.extend(v.to_le_bytes());
        }
    }
    head.extend(data);
    head
}

/// A material whose every table is constant: rgb (0.5, 1, 2), ndf 3, sigma 1.5, and a
/// uniform VNDF (whose inversion lands anywhere: rgb is the same there). eval =
/// rgb * ndf / (4 sigma) = rgb * 0.5, and f_r = eval / cos(theta_o): at theta_o = 60
/// degrees (cos 0.5), f_r = rgb; Y = 0.2126 * 0.5 + 0.7152 + 0.0722 * 2 = 0.9659.
fn constant_material() -> Vec<(&'static str, Vec<u64>, Vec<f32>)> {
    let n = 4;
    vec![
        ("theta_i", vec![2], vec![0.0, 1.5]),
        ("phi_i", vec![1], vec![0.0]),
        ("ndf", vec![n, n], vec![3.0; 16]),
        ("sigma", vec![n, n], vec![1.5; 16]),
        ("vndf", vec![1, 2, n, n], vec![1.0; 32]),
        (
            "rgb",
            vec![1, 2, 3, n, n],
            [[0.5f32; 16], [1.0; 16], [2.0; 16]].concat().repeat(2),
        ),
    ]
}

#[test]
fn a_constant_material_gives_its_hand_derived_value() {
    let m =
        RglBrdf::from_fields(&read_tensor(&tensor_bytes(&constant_material())).unwrap()).unwrap();
    for (c, want) in [
        (RglChannel::R, 0.5),
        (RglChannel::G, 1.0),
        (RglChannel::B, 2.0),
        (RglChannel::Y, 0.9659),
    ] {
        for ti in [0.0, 25.0, 80.0] {
            let got = m.in_plane(c, ti, -60.0);
            assert!((got - want).abs() < 1e-12, "{} at {ti}: {got}", c.name());
            let got = m.in_plane(c, ti, 60.0);
            assert!((got - want).abs() < 1e-12, "{} at {ti}: {got}", c.name());
        }
    }
}

#[test]
fn damaged_files_are_refused_in_one_line() {
    let good = tensor_bytes(&constant_material());
    let mut lying = good.clone();
    // The first field's first dimension (after magic, version, count, name length 2,
    // "theta_i" 7, rank 2, type 1, offset 8) claims 2^40 elements.
    let at = 12 + 2 + 4 + 2 + 7 + 2 + 1 + 8;
    lying[at..at + 8].copy_from_slice(&(1u64 << 40).to_le_bytes());
    let mut nan = constant_material();
    nan[3].2[5] = f32::NAN;
    let mut no_rgb = constant_material();
    no_rgb.pop();
    let mut wrong_shape = constant_material();
    wrong_shape[4].1 = vec![1, 3, 4, 4];
    wrong_shape[4].2 = vec![1.0; 48];
    let check = |bytes: &[u8], says: &str| {
        let e = read_tensor(bytes)
            .and_then(|f| RglBrdf::from_fields(&f).map(drop))
            .unwrap_err();
        assert!(e.contains(says) && !e.contains('\n'), "{says}: {e}");
    };
    check(&good[..good.len() - 3], "does not fit in the file");
    check(&good[..30], "cut short");
    check(b"tensor_filX\0\x01\x00\0\0\0\0", "not an RGL tensor file");
    check(b"tensor_file\0\x02\x00\0\0\0\0", "version 2.0");
    check(&lying, "does not fit in the file");
    check(&tensor_bytes(&nan), "not finite");
    check(&tensor_bytes(&no_rgb), "no 'rgb' field");
    check(
        &tensor_bytes(&wrong_shape),
        "do not match 1 phi_i x 2 theta_i",
    );
}
/// (theta_i, theta_r, f_r of Y, 530 nm (the file's), 555 and 405 nm (between the file's))
/// printed by `rgl_reference.py rgl_spectral_handmade.bsdf --nm 555 --nm 405 ...`.
const SPECTRAL_REFERENCE: [(f64, f64, [f64; 4]); 7] = [
    (
        0.0,
        0.0,
        [
            0.10208414367807493,
            0.11752228716920665,
            0.10393009418526912,
            0.11640614677841875,
        ],
    ),
    (
        20.0,
        15.0,
        [
            0.1414720284202163,
            0.15557315760727408,
            0.14013134830404775,
            0.19417739958531688,
        ],
    ),
    (
        20.0,
        -40.0,
        [
            0.34401653283857997,
            0.3790454601799446,
            0.34115161614594214,
            0.4688492465869224,
        ],
    ),
    (
        35.0,
        30.0,
        [
            0.1586431924076062,
            0.16877241030577733,
            0.15410166215757137,
            0.24334923981379275,
        ],
    ),
    (
        60.0,
        -75.0,
        [
            1.5200818330752601,
            1.4804547146114821,
            1.4508177424866013,
            2.3280354033972235,
        ],
    ),
    (
        10.0,
        85.0,
        [
            1.8425702911203388,
            2.074258405546743,
            1.8507843346776363,
            2.312641763129382,
        ],
    ),
    (
        89.0,
        60.0,
        [
            0.45496888917859096,
            0.39790021909495943,
            0.4280556496450391,
            0.6650202064435178,
        ],
    ),
];

/// The fields of the committed hand-made spectral material (9 wavelengths 380..780 nm).
fn spectral_fields() -> BTreeMap<String, crate::import::tensor::Field> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/rgl_spectral_handmade.bsdf");
    read_tensor(&std::fs::read(path).unwrap()).unwrap()
}

#[test]
fn a_spectral_material_matches_an_independent_evaluation() {
    let m = RglBrdf::from_fields(&spectral_fields()).unwrap();
    assert_eq!(m.wavelengths().unwrap().len(), 9);
    assert!(m.description.starts_with("hand-made spectral"));
    for (ti, tr, want) in SPECTRAL_REFERENCE {
        for (c, w) in [
            RglChannel::Y,
            RglChannel::Nm(530.0),
            RglChannel::Nm(555.0),
            RglChannel::Nm(405.0),
        ]
        .into_iter()
        .zip(want)
        {
            m.check(c).unwrap();
            let got = m.in_plane(c, ti, tr);
            assert!(
                (got - w).abs() <= 1e-9 * w,
                "{ti} {tr} {}: {got} vs {w}",
                c.name()
            );
        }
    }
    // Between two wavelengths is the mean of both (the interpolant's own line).
    let (a, b, mid) = (
        m.in_plane(RglChannel::Nm(530.0), 20.0, 15.0),
        m.in_plane(RglChannel::Nm(580.0), 20.0, 15.0),
        m.in_plane(RglChannel::Nm(555.0), 20.0, 15.0),
    );
    assert!((mid - 0.5 * (a + b)).abs() < 1e-12, "{a} {b} {mid}");
    assert_eq!(m.in_plane(RglChannel::Y, 20.0, -90.0), 0.0);
}

/// A spectrally flat material's Y is its value at any wavelength (the weights sum to
/// 1), whatever its grid: the luminance factor under an equal-energy illuminant.
#[test]
fn a_flat_spectrum_has_its_own_value_as_y() {
    let mut f = spectral_fields();
    let s = f.get_mut("spectra").unwrap();
    let n = s.shape[3] * s.shape[4];
    let per_wl = s.values[..n].to_vec();
    for chunk in s.values.chunks_exact_mut(n) {
        chunk.copy_from_slice(&per_wl);
    }
    let m = RglBrdf::from_fields(&f).unwrap();
    for (ti, tr) in [(0.0, 0.0), (20.0, -40.0), (60.0, 50.0)] {
        let (y, v) = (
            m.in_plane(RglChannel::Y, ti, tr),
            m.in_plane(RglChannel::Nm(600.0), ti, tr),
        );
        assert!((y - v).abs() < 1e-12 * v, "{ti} {tr}: {y} vs {v}");
    }
}

#[test]
fn a_spectral_file_refuses_what_it_cannot_give() {
    let m = RglBrdf::from_fields(&spectral_fields()).unwrap();
    let says = |c: RglChannel, words: &str| {
        let e = m.check(c).unwrap_err();
        assert!(e.contains(words) && !e.contains('\n'), "{words}: {e}");
    };
    says(RglChannel::R, "has no r, g, b");
    says(
        RglChannel::Nm(379.0),
        "outside the file's wavelengths 380..780 nm",
    );
    says(RglChannel::Nm(780.5), "outside the file's wavelengths");
    says(RglChannel::Nm(f64::NAN), "outside the file's wavelengths");
    m.check(RglChannel::Nm(780.0)).unwrap();
    let rgb = real();
    assert!(
        rgb.check(RglChannel::Nm(550.0))
            .unwrap_err()
            .contains("an RGB file has channels r, g, b and y")
    );
    // Wavelengths 500..900 nm leave out the 6.8 % of ybar below 500 nm (the trapezoid
    // sum of the 1 nm table, checked in Python): no Y, a wavelength yes.
    let mut f = spectral_fields();
    for (k, w) in f
        .get_mut("wavelengths")
        .unwrap()
        .values
        .iter_mut()
        .enumerate()
    {
        *w = 500.0 + 50.0 * k as f64;
    }
    let narrow = RglBrdf::from_fields(&f).unwrap();
    let e = narrow.check(RglChannel::Y).unwrap_err();
    assert!(
        e.contains("span 93.2 % of the CIE 1931 ybar integral"),
        "{e}"
    );
    narrow.check(RglChannel::Nm(510.0)).unwrap();
}

#[test]
fn damaged_spectral_files_are_refused_in_one_line() {
    let check = |f: &BTreeMap<String, crate::import::tensor::Field>, says: &str| {
        let e = RglBrdf::from_fields(f).map(drop).unwrap_err();
        assert!(e.contains(says) && !e.contains('\n'), "{says}: {e}");
    };
    let mut f = spectral_fields();
    f.get_mut("wavelengths").unwrap().values[3] = 420.0;
    check(&f, "not positive and increasing");
    let mut f = spectral_fields();
    f.remove("wavelengths");
    check(&f, "no 'wavelengths' field: not an RGL spectral material");
    let mut f = spectral_fields();
    let s = f.get_mut("spectra").unwrap();
    s.shape[2] = 3;
    s.values.truncate(s.values.len() / 3);
    check(&f, "a spectral file whose fields do not match");
    let mut f = spectral_fields();
    f.get_mut("luminance").unwrap().shape = vec![1, 3, 25, 1];
    check(&f, "luminance [1, 3, 25, 1]");
    let mut f = spectral_fields();
    f.get_mut("spectra").unwrap().shape = vec![1, 3, 9, 25];
    check(&f, "rank 5 f32");
}

/// Issue 50 case 9: wavelengths that span ybar but cannot integrate it (380 and 780 nm
/// alone gave Y 31 % below the file's own 560 nm value) give no Y; the committed
/// 50 nm grid integrates ybar within 1.3 % and does.
#[test]
fn y_needs_wavelengths_that_integrate_ybar() {
    let e = y_weights(&[380.0, 780.0]).unwrap_err();
    assert!(
        e.contains(
            "2 wavelengths 380..780 nm integrate the CIE 1931 ybar with an error of 100.0 %"
        ),
        "{e}"
    );
    let grid: Vec<f64> = (0..9).map(|k| 380.0 + 50.0 * f64::from(k)).collect();
    let w = y_weights(&grid).unwrap();
    assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    let q: f64 = grid
        .iter()
        .enumerate()
        .map(|(k, &nm)| {
            crate::import::cie::ybar(nm) * 0.5 * (grid[(k + 1).min(8)] - grid[k.saturating_sub(1)])
        })
        .sum();
    let err = (q / crate::import::cie::ybar_integral(380.0, 780.0) - 1.0).abs();
    assert!(err < Y_MAX_ERROR && err > 0.005, "{err}");
}
