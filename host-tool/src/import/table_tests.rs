//! Tests of `import table` on hand-made tables (values derived by hand in each
//! comment) and on the committed Scatterworks file, checked against the sweep its
//! README's awk command made from it.

use super::*;

fn spec(columns: &str) -> TableSpec {
    TableSpec {
        columns: parse_columns(columns).unwrap().required,
        delimiter: None,
        decimal_comma: false,
        radians: false,
        sign: ThetaRSign::Specular,
        no_header: false,
        skip_lines: 0,
        units: BrdfUnits::PerSr,
        std: parse_columns(columns).unwrap().std,
    }
}

#[test]
fn columns_are_mapped_by_name_in_any_order_and_case() {
    let t = read_table(
        "# an instrument's export\nBRDF,aos,AOI,note\n0.5,-10,20,x\n1.5,30,20,y\n",
        &spec("theta_i=aoi,theta_r=AOS,brdf=brdf"),
    )
    .unwrap();
    assert_eq!(t.rows, vec![(20.0, -10.0, 0.5), (20.0, 30.0, 1.5)]);
    assert_eq!(t.delimiter, Delimiter::Char(b','));
}

#[test]
fn semicolons_decimal_commas_radians_and_the_source_side_sign() {
    // 0,5 rad = 28.6479 degrees (0.5 * 180 / pi); theta_r -0,25 rad on the source's
    // side is +0.25 rad on the specular side = 14.3239 degrees.
    let mut s = spec("theta_i=Theta_i,theta_r=Theta_s,brdf=BRDF");
    s.decimal_comma = true;
    s.radians = true;
    s.sign = ThetaRSign::Source;
    let t = read_table("Theta_i;Theta_s;BRDF\r\n0,5;-0,25;1,25E-3\r\n", &s).unwrap();
    assert_eq!(t.delimiter, Delimiter::Char(b';'));
    let (ti, tr, f) = t.rows[0];
    assert!((ti - 28.647_889_756_541_16).abs() < 1e-12, "{ti}");
    assert!((tr - 14.323_944_878_270_58).abs() < 1e-12, "{tr}");
    assert_eq!(f, 1.25e-3);
    // Tab, sniffed.
    let t = read_table("a\tb\tc\n10\t20\t3\n", &spec("theta_i=a,theta_r=b,brdf=c")).unwrap();
    assert_eq!(
        (t.rows[0], t.delimiter),
        ((10.0, 20.0, 3.0), Delimiter::Char(b'\t'))
    );
}

#[test]
fn bad_tables_are_refused_with_their_line() {
    let cols = "theta_i=AOI,theta_r=AOS,brdf=BRDF";
    for (text, decimal_comma, line, says) in [
        (
            "AOI;AOS;Value\n1;2;3\n",
            false,
            1,
            "no column 'BRDF' for brdf: the header row holds 3 column(s) separated by ';': 'AOI' 'AOS' 'Value'",
        ),
        (
            "AOI,AOS,BRDF,BRDF\n1,2,3,4\n",
            false,
            1,
            "column 'BRDF' appears more than once",
        ),
        (
            "AOI,AOS,BRDF\n10,20\n",
            false,
            2,
            "2 field(s) where the header row has 3",
        ),
        (
            "AOI,AOS,BRDF\n10,20,nan\n",
            false,
            2,
            "brdf 'nan' is not a finite number",
        ),
        (
            "AOI,AOS,BRDF\n10,20,inf\n",
            false,
            2,
            "brdf 'inf' is not a finite number",
        ),
        (
            "AOI,AOS,BRDF\n-5,20,1\n",
            false,
            2,
            "theta_i -5 degrees is outside [0, 90]",
        ),
        (
            "AOI,AOS,BRDF\n10,120,1\n",
            false,
            2,
            "theta_r 120 degrees is outside [-90, 90]",
        ),
        (
            "AOI,AOS,BRDF\n10,20,1e31\n",
            false,
            2,
            "outside the magnitudes gonio fits",
        ),
        ("AOI,AOS,BRDF\n", false, 1, "a header row but no rows"),
        ("# only comments\n\n", false, 1, "no table"),
        (
            "AOI,AOS,BRDF\n10,20,1\n",
            true,
            1,
            "--decimal-comma with ',' as the delimiter",
        ),
        (
            "AOI;AOS;BRDF\n1.000,5;2;3\n",
            true,
            2,
            "theta_i '1.000,5' is not a finite number",
        ),
    ] {
        let mut s = spec(cols);
        s.decimal_comma = decimal_comma;
        let (l, m) = read_table(text, &s).unwrap_err();
        assert!(m.contains(says) && !m.contains('\n'), "{text:?}: {m}");
        assert_eq!(l, line, "{text:?}: {m}");
    }
}

#[test]
fn column_specs_are_checked() {
    assert_eq!(
        parse_columns("brdf=3, theta_r=AOS ,theta_i=1").unwrap(),
        Columns {
            required: [
                ColumnRef::Position(1),
                ColumnRef::Name("AOS".into()),
                ColumnRef::Position(3)
            ],
            std: None
        }
    );
    assert_eq!(
        parse_columns("theta_i=a,theta_r=b,brdf=c,STD=4")
            .unwrap()
            .std,
        Some(ColumnRef::Position(4))
    );
    for (bad, says) in [
        ("theta_i=a,theta_r=b", "needs theta_i"),
        (
            "theta_i=a,theta_r=b,brdf=c,theta_i=d",
            "names theta_i twice",
        ),
        ("phi=a,theta_r=b,brdf=c", "'phi' is not one of"),
        ("theta_i,theta_r=b,brdf=c", "expected QUANTITY=COLUMN"),
        ("theta_i=,theta_r=b,brdf=c", "no column after '='"),
        ("theta_i=a,theta_r=b,std=c", "needs theta_i"),
        ("theta_i=a,theta_r=b,brdf=c,std=d,std=e", "names std twice"),
    ] {
        let e = parse_columns(bad).unwrap_err();
        assert!(e.contains(says), "{bad}: {e}");
    }
    let mut s = spec("theta_i=a,theta_r=2,brdf=3");
    s.no_header = true;
    let (_, m) = read_table("1 2 3\n", &s).unwrap_err();
    assert!(m.contains("theta_i must be a column number"), "{m}");
}

/// The committed Scatterworks table (whitespace-aligned, its header inside a `#`
/// comment) read by column number reproduces, row for row, the sweep the data
/// README's awk command made from it (which drops the |theta_r| = 90 rows).
#[test]
fn the_scatterworks_table_matches_its_awk_conversion() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let original = std::fs::read_to_string(dir.join("scatterworks-solar-array-532nm.csv")).unwrap();
    let mut s = spec("theta_i=1,theta_r=3,brdf=5");
    s.no_header = true;
    let t = read_table(&original, &s).unwrap();
    assert_eq!(t.delimiter, Delimiter::Whitespace);
    assert_eq!(t.rows.len(), 724);
    let kept: Vec<_> = t.rows.iter().filter(|r| r.1.abs() != 90.0).collect();
    let awk = crate::sweep_file::read_sweep(&dir.join("scatterworks-solar-array-532nm.sweep.csv"))
        .unwrap();
    assert_eq!(kept.len(), awk.rows.len());
    for (a, b) in kept.iter().zip(&awk.rows) {
        assert_eq!((a.0, a.1, a.2), (b.theta_i, b.theta_r, b.brdf));
    }
}

/// A std column is read per row, refused when negative or not finite, and written as
/// the sweep's std with n = 1, which the sweep reader and the fit's dataset take as
/// each reading's standard error (std / sqrt(1)).
#[test]
fn a_std_column_becomes_the_sweeps_std() {
    let s = spec("theta_i=AOI,theta_r=AOS,brdf=BRDF,std=Sigma");
    let t = read_table("AOI;AOS;BRDF;Sigma\n20;-10;0.5;0.01\n20;30;1.5;0\n", &s).unwrap();
    assert_eq!(t.rows, vec![(20.0, -10.0, 0.5), (20.0, 30.0, 1.5)]);
    assert_eq!(t.std, vec![0.01, 0.0]);
    // Without std=..., no std is read even when the table has the column.
    let t3 = read_table(
        "AOI;AOS;BRDF;Sigma\n20;-10;0.5;0.01\n",
        &spec("theta_i=AOI,theta_r=AOS,brdf=BRDF"),
    )
    .unwrap();
    assert!(t3.std.is_empty());
    for (text, says) in [
        (
            "AOI,AOS,BRDF,Sigma\n20,-10,0.5,-0.01\n",
            "std -0.01 is negative",
        ),
        (
            "AOI,AOS,BRDF,Sigma\n20,-10,0.5,nan\n",
            "std 'nan' is not a finite number",
        ),
        (
            "AOI,AOS,BRDF,Sigma\n20,-10,0.5,inf\n",
            "std 'inf' is not a finite number",
        ),
        (
            "AOI,AOS,BRDF,Sigma\n20,-10,0.5\n",
            "3 field(s) where the header row has 4",
        ),
        ("AOI,AOS,BRDF\n20,-10,0.5\n", "no column 'Sigma' for std"),
    ] {
        let (line, m) = read_table(text, &s).unwrap_err();
        assert!(m.contains(says) && !m.contains('\n'), "{text:?}: {m}");
        assert_eq!(line, if says.starts_with("no column") { 1 } else { 2 });
    }
    let mut out = Vec::new();
    crate::import::write_sweep(&mut out, &["brdf: 1/sr".into()], &t.rows, &t.std).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.csv");
    std::fs::write(&path, &out).unwrap();
    let sweep = crate::sweep_file::read_sweep(&path).unwrap();
    let got: Vec<_> = sweep.rows.iter().map(|r| (r.std, r.n)).collect();
    assert_eq!(got, vec![(Some(0.01), Some(1)), (Some(0.0), Some(1))]);
}

/// Issue 50 case 2: a row of another width than the header row is refused with its
/// line: a decimal comma under four columns (`10,10,2,5,4` was read as brdf 2), a
/// whitespace row with a blank cell (took its brdf from the next column), a row of
/// another width than the first where there is no header.
#[test]
fn a_row_of_another_width_is_refused_never_read_by_position() {
    let s = spec("theta_i=theta_i,theta_r=theta_r,brdf=brdf");
    let (line, msg) =
        read_table("theta_i,theta_r,brdf,n\n10,20,3,1\n10,10,2,5,4\n", &s).unwrap_err();
    assert_eq!(line, 3);
    assert!(
        msg.starts_with("5 field(s) where the header row has 4") && msg.contains("--decimal-comma"),
        "{msg}"
    );
    let (line, msg) = read_table("theta_i theta_r brdf n\n10 20 3 1\n10 30 4\n", &s).unwrap_err();
    assert_eq!(line, 3);
    assert!(
        msg.contains("3 field(s) where the header row has 4") && msg.contains("blank cell"),
        "{msg}"
    );
    let mut s = spec("theta_i=1,theta_r=2,brdf=3");
    s.no_header = true;
    let (line, msg) = read_table("10,20,3\n10,30,4,7\n", &s).unwrap_err();
    assert_eq!(line, 2);
    assert!(
        msg.contains("4 field(s) where the first row has 3"),
        "{msg}"
    );
}
