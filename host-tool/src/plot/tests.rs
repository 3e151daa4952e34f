//! Tests of the figures on a synthetic fit (the fe-0.115 preset on the paper grid).

use std::path::PathBuf;
use std::sync::OnceLock;

use super::*;
use crate::fit::{FitOptions, fit_family};
use crate::sweep_file::Row;
use brdf_core::Preset;
use brdf_core::member::Member;

/// Paper-grid rows of a preset with 3 % multiplicative noise; `skip_specular` leaves the
/// reading at theta_r = theta_i out at the listed incidences.
fn rows(name: &str, skip_specular: &[f64]) -> Vec<Row> {
    let p = Preset::by_name(name).unwrap();
    crate::fit::data::synthetic_paper_sweep(|ti| p.model(ti).unwrap(), 0.03, 7)
        .into_iter()
        .filter(|r| !(r.theta_r == r.theta_i && skip_specular.contains(&r.theta_i)))
        .collect()
}

fn fixture() -> &'static (Dataset, FamilyFit) {
    static F: OnceLock<(Dataset, FamilyFit)> = OnceLock::new();
    F.get_or_init(|| {
        let data = Dataset::from_rows(&rows("fe-0.115", &[]), true).unwrap();
        let fam = fit_family(&data, &FitOptions::default()).unwrap();
        (data, fam)
    })
}

fn tempdir(name: &str) -> PathBuf {
    // A private parent; the directory itself is left for write_plots to create.
    crate::outfile::test_dir("plot").join(name)
}

/// Width and height from a PNG's signature and IHDR chunk.
fn png_size(bytes: &[u8]) -> (u32, u32) {
    assert!(bytes.len() > 33, "too short for a PNG");
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
    assert_eq!(&bytes[12..16], b"IHDR", "first chunk is IHDR");
    let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
    (be(&bytes[16..20]), be(&bytes[20..24]))
}

#[test]
fn writes_one_png_and_svg_per_incidence_and_an_overview() {
    let (data, fam) = fixture();
    let dir = tempdir("all");
    let files = write_plots(&dir, data, fam, false).unwrap();
    let names: Vec<String> = files
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    let mut expected = Vec::new();
    for t in (0..=80).step_by(10) {
        expected.push(format!("theta_i_{t}.png"));
        expected.push(format!("theta_i_{t}.svg"));
    }
    expected.push("overview.png".into());
    expected.push("overview.svg".into());
    assert_eq!(names, expected);
    for f in &files {
        assert_eq!(f.parent().unwrap(), dir);
        let bytes = std::fs::read(f).unwrap();
        let name = f.file_name().unwrap().to_string_lossy();
        if name.ends_with(".png") {
            let size = if name.starts_with("overview") {
                OVERVIEW_SIZE
            } else {
                INCIDENCE_SIZE
            };
            assert_eq!(png_size(&bytes), size, "{name}");
        } else {
            let text = String::from_utf8(bytes).unwrap();
            assert!(text.starts_with("<svg"), "{name}");
            assert!(text.contains("theta_r (degrees)"), "{name}: x label");
            let y = if name.starts_with("overview") {
                y_desc_absolute(fam.units)
            } else {
                Y_DESC_NORMALISED
            };
            assert!(text.contains(y), "{name}: y label");
        }
    }
    let svg = std::fs::read_to_string(dir.join("theta_i_20.svg")).unwrap();
    assert!(
        svg.contains("theta_i = 20 degrees"),
        "title names the incidence"
    );
    assert!(svg.contains("RMSE"), "title gives the RMSE");
    assert!(svg.contains(&format!("{} (selected)", display_name(fam.selected))));
    assert!(svg.contains("Torrance–Sparrow"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn rmse_of_each_model_is_in_the_title() {
    let (data, fam) = fixture();
    let fig = incidence_figure(data, fam, 2);
    let ts = fam.member(Member::TORRANCE_SPARROW).unwrap().rmse_by_inc[2].unwrap();
    let three = fam.member(Member::THREE_COMPONENT).unwrap().rmse_by_inc[2].unwrap();
    assert!(
        fig.subtitles[0].contains(&format!("{ts:.4}")),
        "{:?}",
        fig.subtitles
    );
    assert!(
        fig.subtitles[0].contains(&format!("{three:.4}")),
        "{:?}",
        fig.subtitles
    );
}

#[test]
fn normalised_curves_and_points_are_one_at_the_specular_angle() {
    let (data, fam) = fixture();
    let j = 3; // 30 degrees
    let fig = incidence_figure(data, fam, j);
    let spec = fig.markers[0].points.iter().find(|p| p.0 == 30.0).unwrap();
    assert_eq!(spec.1, 1.0);
    assert!(fig.curves.len() >= 2);
    for c in &fig.curves {
        let p = c.points.iter().find(|p| p.0 == 30.0).unwrap();
        assert!((p.1 - 1.0).abs() < 1e-12);
        assert_eq!(c.points.first().unwrap().0, -90.0);
        assert_eq!(c.points.last().unwrap().0, 90.0);
        // Every 0.5 degree, and every 0.02 degree within 3 degrees of the mirror.
        assert_eq!(c.points.iter().filter(|p| p.0.abs() > 40.0).count(), 200);
        assert!(c.points.iter().filter(|p| (p.0 - 30.0).abs() < 0.5).count() > 40);
    }
}

#[test]
fn without_a_specular_reading_curves_are_divided_at_the_nearest_reading_and_the_title_says_so() {
    let data = Dataset::from_rows(&rows("fe-0.115", &[20.0]), true).unwrap();
    let fam = fit_family(&data, &FitOptions::default()).unwrap();
    let fig = incidence_figure(&data, &fam, 2);
    assert!(
        fig.subtitles
            .iter()
            .any(|s| s.contains("No reading at theta_r = theta_i")),
        "{:?}",
        fig.subtitles
    );
    // The readings nearest to 20 degrees are at 10 and 30; the first (10) is the
    // reference: measured and every curve are 1 there.
    let at = |pts: &[(f64, f64)]| pts.iter().find(|p| p.0 == 10.0).unwrap().1;
    assert_eq!(at(&fig.markers[0].points), 1.0);
    for c in &fig.curves {
        assert!((at(&c.points) - 1.0).abs() < 1e-12);
    }
    assert!(
        fig.subtitles
            .iter()
            .any(|s| s.contains("nearest reading, theta_r = 10"))
    );
    // Issue 13: the paper RMSE is normalised at the nearest reading, never n/d.
    assert!(
        !fig.subtitles[0].contains("n/d"),
        "paper RMSE at the nearest reading: {:?}",
        fig.subtitles
    );
}

#[test]
fn an_unwritable_directory_is_a_failure_naming_it() {
    let (data, fam) = fixture();
    let dir = tempdir("file");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("not-a-dir");
    std::fs::write(&file, b"x").unwrap();
    let err = write_plots(&file.join("plots"), data, fam, false).unwrap_err();
    // A PlotError is a failed job (exit 1) by its type.
    let PlotError(message) = err;
    assert!(message.contains("not-a-dir"), "{message}");
    assert!(!message.contains('\n'));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn log_ticks_label_every_range() {
    for (lo, hi) in [
        (0.4, 1.8),
        (0.05, 1.8),
        (1e-3, 2.0),
        (1e-7, 1e3),
        (20.0, 5000.0),
    ] {
        let (t, light) = log_ticks(lo, hi);
        assert!(light.iter().all(|&v| v >= lo && v <= hi));
        assert!(t.len() >= 2, "{lo}..{hi}: {t:?}");
        assert!(t.iter().all(|&v| v >= lo && v <= hi));
        assert!(t.len() <= 12, "{lo}..{hi}: {t:?}");
    }
    assert_eq!(tick_text(0.30000000000000004), "0.3");
    assert_eq!(tick_text(1000.0), "1000");
    assert_eq!(tick_text(1e-5), "1e-5");
    assert_eq!(angle_text(22.5), "22.5");
    assert_eq!(angle_text(-0.0), "0");
}

#[test]
fn notes_wrap_at_spaces() {
    assert_eq!(wrap("aaa bbb ccc", 7), vec!["aaa bbb", "ccc"]);
    assert_eq!(
        wrap("averyveryverylongword x", 5),
        vec!["averyveryverylongword", "x"]
    );
}

#[test]
fn long_member_names_wrap_after_a_plus_and_keep_every_character() {
    use super::figures::wrap;
    let name = "specular:ggx:smooth-ks+specular-haze:ggx+ideal-diffuse (selected)";
    let lines = wrap(name, 32);
    assert!(lines.len() > 1, "{lines:?}");
    assert!(lines.iter().all(|l| l.chars().count() <= 32), "{lines:?}");
    assert_eq!(
        lines
            .concat()
            .replace("(selected)", " (selected)")
            .replace("  ", " "),
        name
    );
    assert_eq!(lines[0], "specular:ggx:smooth-ks+");
    // Short labels are one line.
    assert_eq!(wrap("measured", 32), ["measured"]);
}

#[test]
fn the_overview_says_the_fits_units() {
    use crate::sweep_file::BrdfUnits;
    assert_eq!(y_desc_absolute(BrdfUnits::PerSr), "BRDF (1/sr)");
    assert_eq!(
        y_desc_absolute(BrdfUnits::Relative),
        "BRDF (relative units)"
    );
}

#[test]
fn component_curves_are_clipped_to_the_chart_not_drawn_along_its_edge() {
    use super::render::clip_runs;
    // A curve falling through the bottom bound and rising back.
    let pts = [
        (0.0, 10.0),
        (1.0, 1.0),
        (2.0, 0.01),
        (3.0, 0.001),
        (4.0, 1.0),
    ];
    let runs = clip_runs(&pts, 0.1, 100.0);
    assert_eq!(runs.len(), 2, "{runs:?}");
    for r in &runs {
        assert!(r.iter().all(|p| (0.1..=100.0).contains(&p.1)), "{r:?}");
    }
    // The crossings sit on the bound, interpolated in ln y: 1 -> 0.01 meets 0.1 half way.
    let end = runs[0].last().unwrap();
    assert!(
        (end.0 - 1.5).abs() < 1e-12 && (end.1 - 0.1).abs() < 1e-15,
        "{end:?}"
    );
    let start = runs[1][0];
    assert!((start.0 - (3.0 + 2.0 / 3.0)).abs() < 1e-12, "{start:?}");
    // Wholly outside: nothing to draw.
    assert!(clip_runs(&[(0.0, 1e-6), (1.0, 1e-5)], 0.1, 1.0).is_empty());
}

#[test]
fn curves_beyond_the_readings_are_split_off_at_the_span_edge() {
    use super::render::split_at_span;
    let pts: Vec<(f64, f64)> = (-4..=4).map(|k| (k as f64 * 25.0, 10f64.powi(k))).collect();
    let parts = split_at_span(&pts, Some((-80.0, 80.0)));
    let kinds: Vec<bool> = parts.iter().map(|p| p.0).collect();
    assert_eq!(kinds, [false, true, false], "{parts:?}");
    // Joined at the edges, interpolated in ln y: -100 (1e-4) to -75 (1e-3) meets -80
    // four fifths of the way.
    let left_end = *parts[0].1.last().unwrap();
    assert_eq!(left_end, parts[1].1[0]);
    assert!((left_end.0 + 80.0).abs() < 1e-12, "{left_end:?}");
    assert!((left_end.1.log10() + 3.2).abs() < 1e-12, "{left_end:?}");
    assert_eq!(parts[1].1.last(), parts[2].1.first());
    // Without readings, one solid piece.
    assert_eq!(split_at_span(&pts, None), vec![(true, pts.clone())]);
}

#[test]
fn each_component_has_its_own_dash_and_legend_entry() {
    let (data, fam) = fixture();
    let fig = incidence_figure(data, fam, 0);
    assert!(fig.lobes.len() >= 3, "{}", fig.lobes.len());
    let dashes: Vec<super::figures::Dash> = fig.lobes.iter().map(|l| l.dash).collect();
    for (i, a) in dashes.iter().enumerate() {
        assert!(!dashes[i + 1..].contains(a), "{dashes:?}");
    }
    let entries: Vec<&String> = fig
        .legend
        .iter()
        .filter(|(s, _)| matches!(s, super::figures::Swatch::Dashed(..)))
        .map(|(_, t)| t)
        .collect();
    assert_eq!(entries.len(), fig.lobes.len(), "{entries:?}");
    assert!(
        entries.iter().any(|t| t.contains("ideal diffuse")),
        "{entries:?}"
    );
}

#[test]
fn with_instrument_angles_the_figures_are_drawn_at_the_sample() {
    let (data, _) = fixture();
    let opts = FitOptions {
        offset: Some(crate::fit::offset::OffsetSpec::Detector(0.5)),
        ..FitOptions::default()
    };
    let fam = fit_family(data, &opts).unwrap();
    let dir = tempdir("angles");
    write_plots(&dir, data, &fam, false).unwrap();
    let svg = std::fs::read_to_string(dir.join("theta_i_20.svg")).unwrap();
    assert!(svg.contains("Angles at the sample"), "the note says so");
    // The readings sit where the fit saw them: 0.5 degrees below their labels.
    let (local, _) = fam.angles.as_ref().unwrap().apply(data).unwrap();
    let fig = incidence_figure(&local, &fam, 2);
    assert!(
        fig.markers[0]
            .points
            .iter()
            .any(|p| (p.0 - 19.5).abs() < 1e-9)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn svg_curves_keep_fractional_pixels_and_replace_the_placeholder() {
    let (data, fam) = fixture();
    let dir = tempdir("fractional");
    write_plots(&dir, data, fam, false).unwrap();
    let svg = std::fs::read_to_string(dir.join("theta_i_20.svg")).unwrap();
    assert!(!svg.contains("#010203"), "placeholder left in the SVG");
    let curves: Vec<&str> = svg
        .lines()
        .filter(|l| l.contains("stroke-linejoin=\"round\""))
        .collect();
    assert!(curves.len() >= 3, "{}", curves.len());
    // Stair steps would be whole pixels only: most points of a smooth curve are not.
    let points: Vec<&str> = curves
        .iter()
        .flat_map(|l| l.split("points=\"").nth(1).unwrap().split(['"', ' ']))
        .filter(|p| p.contains(','))
        .collect();
    let fractional = points.iter().filter(|p| p.contains('.')).count();
    assert!(
        fractional * 2 > points.len(),
        "{fractional} of {}",
        points.len()
    );
    // The curves are drawn before the measured points (which stay on top).
    let first_curve = svg.find("stroke-linejoin").unwrap();
    let first_marker = svg.find("<circle").unwrap();
    assert!(first_curve < first_marker);
}

#[test]
fn pixel_map_is_plotters_map_unrounded() {
    use super::stroke::PixelMap;
    let m = PixelMap::new((-90.0, 0.01), (90.0, 100.0), (100, 500), (900, 100));
    assert_eq!(m.at((-90.0, 0.01)), (100.0, 500.0));
    let (x, y) = m.at((0.0, 1.0));
    assert!(
        (x - 500.0).abs() < 1e-9 && (y - 300.0).abs() < 1e-9,
        "{x} {y}"
    );
    let (x, _) = m.at((0.45, 1.0));
    assert!((x - 502.0).abs() < 1e-9, "{x}");
}

#[test]
fn dashes_follow_the_pattern_along_the_curve() {
    use super::stroke::dashes;
    // An L of 10 + 10 pixels in 4-on 3-off dashes: 0-4, 7-11 (round the corner), 14-18.
    let d = dashes(&[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)], 4.0, 3.0);
    assert_eq!(d.len(), 3, "{d:?}");
    assert_eq!(d[0], vec![(0.0, 0.0), (4.0, 0.0)]);
    assert_eq!(d[1], vec![(7.0, 0.0), (10.0, 0.0), (10.0, 1.0)]);
    assert_eq!(d[2], vec![(10.0, 4.0), (10.0, 8.0)]);
}

#[test]
fn bitmap_segments_keep_a_narrow_peak_whole() {
    use super::stroke::segments;
    // Up a column to a sharp peak and back, in sub-pixel steps: every kept segment
    // joins the last, and the peak is reached.
    let mut px: Vec<(f64, f64)> = (0..40).map(|k| (100.0, 200.0 - k as f64 * 2.5)).collect();
    px.extend((0..40).rev().map(|k| (100.4, 200.0 - k as f64 * 2.5)));
    let segs = segments(&px);
    for w in segs.windows(2) {
        assert_eq!(w[0][1], w[1][0], "{segs:?}");
    }
    let top = segs
        .iter()
        .flat_map(|s| s.iter().map(|p| p.1))
        .min()
        .unwrap();
    assert_eq!(top, (200.0f64 - 39.0 * 2.5).round() as i32);
    assert!(segs.iter().all(|s| s[0] != s[1]));
}
