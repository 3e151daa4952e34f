//! Tests of the ASTM reader on hand-made tables: which rows lie in the plane and the
//! sign each gets (derived by hand in the comments), the channels, and refusals.

use super::*;

const RGB: &str = "SOURCE measured\nSAMPLE test tile\nNUM_POINTS 7\nVARS theta_i,phi_i,theta_s,phi_s,R,G,B\n\
0.5,0,0.5,3.14159,1,2,3\n\
0.5,0,0.25,0,4,5,6\n\
0.5,0,0,1.2,7,8,9\n\
0.5,0,0.5,1.5708,10,11,12\n\
0.5,1,0.3,4.14159,13,14,15\n\
0.5,1,0.3,-5.28319,16,17,18\n\
0.5,0,0.5,-3.14159,19,20,21\n";

#[test]
fn in_plane_rows_are_signed_and_others_counted() {
    let s = read_astm(RGB, Some("g")).unwrap();
    assert_eq!(s.channel, "G");
    assert_eq!(s.channels, ["R", "G", "B"]);
    let d = |r: f64| r.to_degrees();
    // Row 1: phi_s - phi_i = 3.14159 ~ pi: specular side, theta_r = +0.5 rad.
    // Row 2: phi_s = phi_i: the source's side, theta_r = -0.25 rad.
    // Row 3: theta_s = 0: theta_r = 0 whatever phi_s.
    // Row 4: phi_s - phi_i = pi/2: out of the plane.
    // Row 5: phi_i = 1, phi_s = 1 + 3.14159: specular side, +0.3 rad.
    // Row 6: phi_s - phi_i = -6.28319 ~ -2 pi, i.e. 0: the source's side, -0.3 rad.
    // Row 7: phi_s = -3.14159 ~ pi (mod 2 pi): specular side, +0.5 rad.
    let want = [
        (d(0.5), d(0.5), 2.0),
        (d(0.5), d(-0.25), 5.0),
        (d(0.5), 0.0, 8.0),
        (d(0.5), d(0.3), 14.0),
        (d(0.5), d(-0.3), 17.0),
        (d(0.5), d(0.5), 20.0),
    ];
    assert_eq!(s.rows.len(), want.len());
    for (got, w) in s.rows.iter().zip(want) {
        assert!(
            (got.0 - w.0).abs() < 1e-12 && (got.1 - w.1).abs() < 1e-12 && got.2 == w.2,
            "{got:?} vs {w:?}"
        );
    }
    assert_eq!(s.out_of_plane, 1);
}

#[test]
fn one_channel_is_taken_without_asking() {
    let s = read_astm(
        "VARS theta_i,phi_i,theta_s,phi_s,550nm\r\n0.1,0,0.2,3.1416,0.25\r\n",
        None,
    )
    .unwrap();
    assert_eq!(
        (s.channel.as_str(), s.rows.len(), s.rows[0].2),
        ("550nm", 1, 0.25)
    );
}

#[test]
fn bad_tables_are_refused_with_their_line() {
    let row = "0.5,0,0.5,3.14159,1";
    let hdr = "VARS theta_i,phi_i,theta_s,phi_s,BRDF";
    for (text, channel, line, says) in [
        ("SOURCE x\n".to_string(), None, 1, "no VARS line"),
        (
            format!("VARS theta_i,theta_s,phi_i,phi_s,BRDF\n{row}\n"),
            None,
            1,
            "the first four must be theta_i,phi_i,theta_s,phi_s",
        ),
        (
            "VARS theta_i,phi_i,theta_s,phi_s\n".to_string(),
            None,
            1,
            "no channel",
        ),
        (
            RGB.to_string(),
            None,
            4,
            "3 channels (R, G, B): choose one with --channel",
        ),
        (
            RGB.to_string(),
            Some("Y"),
            4,
            "no channel 'Y' in VARS (it names R, G, B)",
        ),
        (
            format!("NUM_POINTS 3\n{hdr}\n{row}\n{row}\n"),
            None,
            1,
            "NUM_POINTS 3 but the file holds 2 rows",
        ),
        (
            format!("NUM_POINTS many\n{hdr}\n"),
            None,
            1,
            "NUM_POINTS 'NUM_POINTS many' is not a whole number",
        ),
        (
            format!("{hdr}\n{row}\n0.5,0,0.5,3.14\n"),
            None,
            3,
            "4 values, VARS names 5",
        ),
        (
            format!("{hdr}\n0.5,0,0.5,3.14,nan\n"),
            None,
            2,
            "BRDF 'nan' is not a finite number",
        ),
        (
            format!("{hdr}\n0.5,0,2.0,3.14,1\n"),
            None,
            2,
            "theta_s 2 rad is outside [0, pi/2]",
        ),
        (
            format!("{hdr}\n0.5,0,0.5,3.14159,1e40\n"),
            None,
            2,
            "outside the magnitudes",
        ),
        (
            format!("{hdr}\n0.5,0,0.5,1.5,1\n"),
            None,
            2,
            "no row lies in the plane of incidence (1 out of the plane)",
        ),
    ] {
        let (l, m) = read_astm(&text, channel).unwrap_err();
        assert!(m.contains(says) && !m.contains('\n'), "{text:?}: {m}");
        assert_eq!(l, line, "{text:?}: {m}");
    }
}
