//! Bad input to every subcommand, in one table: the documented exit status (2 bad
//! input, 1 failed job), exactly one line on stderr, no panic, nothing on stdout for bad
//! input, and no output file left looking complete.

use std::path::Path;

use brdf_core::sim::XorShift32;

use crate::util::{Run, Scratch, gonio_command, scratch, simulated};

struct Case {
    /// Arguments; `{d}` is replaced by a scratch directory holding the fixtures.
    args: &'static [&'static str],
    /// Expected exit status.
    code: i32,
    /// Words the message must contain (case-insensitive).
    says: &'static str,
    /// An output path (relative to `{d}`) that must not exist afterwards, or not look
    /// complete if it existed before.
    no_output: Option<&'static str>,
}

const fn case(args: &'static [&'static str], code: i32, says: &'static str) -> Case {
    Case {
        args,
        code,
        says,
        no_output: None,
    }
}

/// A `gonio flash` case: bad input either way; without the `flash` feature (off by
/// default) the message is the one that says how to get a build that flashes.
const fn flash(args: &'static [&'static str], says: &'static str) -> Case {
    let says = if cfg!(feature = "flash") {
        says
    } else {
        "--features flash"
    };
    case(args, 2, says)
}

const fn out(
    args: &'static [&'static str],
    code: i32,
    says: &'static str,
    path: &'static str,
) -> Case {
    Case {
        args,
        code,
        says,
        no_output: Some(path),
    }
}

fn fixtures() -> Scratch {
    let d = scratch("bad");
    let w = |name: &str, bytes: &[u8]| std::fs::write(d.join(name), bytes).unwrap();
    w("empty.csv", b"");
    // A MERL BRDF table (dims header, three channels of 90 x 90 x 180 f64): 35 MB of
    // zeros after its header.
    let mut merl = [90i32, 90, 180]
        .iter()
        .flat_map(|d| d.to_le_bytes())
        .collect::<Vec<u8>>();
    merl.resize(12 + 3 * 8 * 90 * 90 * 180, 0);
    w("gold.binary", &merl);
    // A FIFO named like a MERL table: opening it would wait for a writer for ever.
    nix::unistd::mkfifo(&d.join("pipe.binary"), nix::sys::stat::Mode::S_IRWXU).unwrap();
    let mut garbage = Vec::new();
    let mut rng = XorShift32::new(0x1234_5678);
    for _ in 0..4096 {
        garbage.push((rng.uniform() * 256.0) as u8);
    }
    w("garbage.csv", &garbage);
    w("garbage.toml", &garbage);
    w("garbage.elf", &garbage);
    w("empty.elf", b"");
    w("nocols.csv", b"a,b,c\n1,2,3\n");
    w("header.csv", b"theta_i,theta_r,brdf\n");
    w("nan.csv", b"theta_i,theta_r,brdf\n20,20,NaN\n20,30,5\n");
    w("huge.csv", b"theta_i,theta_r,brdf\n20,20,1e400\n20,30,5\n");
    w("negative.csv", b"theta_i,theta_r,brdf\n20,20,-5\n20,30,5\n");
    w("angles.csv", b"theta_i,theta_r,brdf\n200,20,5\n20,30,5\n");
    w("short.csv", b"theta_i,theta_r,brdf\n20,20\n");
    // Instruments whose K converts readings out of every reader's range (issue 41).
    for (name, k) in [("k-tiny.toml", "1e-300"), ("k-huge.toml", "1e300")] {
        let text = format!(
            "k = {k}\nu_k = 0.0\nstandard = \"lambertian:0.99\"\nreference_file = \"ref.csv\"\ndate = \"2026-12-01T18:30:00Z\"\nreadings = 9\n"
        );
        w(name, text.as_bytes());
    }
    w(
        "rel.csv",
        b"theta_i,theta_r,brdf\n20,20,5\n20,30,4\n20,40,3\n",
    );
    // A reference of readings near 1e20 against a 99 % white standard: K about 3e20.
    let mut bright = b"theta_i,theta_r,brdf\n".to_vec();
    for tr in [-40, -30, -20, -10, 10, 20, 30, 40] {
        bright.extend_from_slice(format!("0,{tr},1e20\n").as_bytes());
    }
    w("bright-ref.csv", &bright);
    // One reading more than a fit takes (MAX_FIT_READINGS), in 17 MB: under the file
    // size limit, so the count is what refuses it.
    let mut too_many = b"theta_i,theta_r,brdf\n".to_vec();
    for _ in 0..=gonio::fit::data::MAX_FIT_READINGS {
        too_many.extend_from_slice(b"10,20,1\n");
    }
    w("too-many.csv", &too_many);
    w(
        "nan.toml",
        b"incidences = [nan]\ndetector = { start = -80, stop = 80, step = 10 }\n",
    );
    w(
        "huge.toml",
        b"incidences = [20]\ndetector = { start = -80, stop = 80, step = 1e-30 }\n",
    );
    w(
        "neg.toml",
        b"incidences = [-20]\ndetector = { start = -80, stop = 80, step = 10 }\n",
    );
    w("both.toml", b"incidences = [20]\npoints = [[20, 20]]\n");
    w(
        "unknown.toml",
        b"incidences = [20]\ndetector = { start = -80, stop = 80, step = 10 }\nsamplez = 3\n",
    );
    w("exists.csv", b"precious\n");
    w("plainfile", b"not a directory\n");
    w("fit-cols.csv", b"theta_i,brdf\n1,2\n");
    w("fit-aoi.csv", b"AOI;AOS;BRDF\n20;20;5\n20;30;4\n20;40;3\n");
    w("table-comma.csv", b"AOI;AOS;BRDF\n20;20;0,5\n");
    w(
        "table-std.csv",
        b"AOI;AOS;BRDF;SIGMA\n20;20;0.5;0.01\n20;25;0.4;-0.01\n",
    );
    w(
        "persr.csv",
        b"# brdf: 1/sr\ntheta_i,theta_r,brdf\n20,20,5\n20,30,4\n20,40,3\n",
    );
    w(
        "brdf-twice.csv",
        b"# brdf: relative\n# brdf: 1/sr\ntheta_i,theta_r,brdf\n20,20,5\n20,30,4\n20,40,3\n",
    );
    // Issue 50 cases 2 and 3: a decimal-comma row under a four-column header (read as
    // brdf 2 by position), metadata keys in another case, a key given twice.
    w(
        "comma-row.csv",
        b"theta_i,theta_r,brdf,std\n10,10,2,5,4\n10,20,3,0.1\n10,30,4,0.1\n",
    );
    w(
        "upper-persr.csv",
        b"# BRDF: 1/sr\ntheta_i,theta_r,brdf\n20,20,5\n20,30,4\n20,40,3\n",
    );
    w(
        "upper-rad.csv",
        b"# Units: radians\ntheta_i,theta_r,brdf\n0.1,0.2,5\n0.1,0.3,4\n0.1,0.4,3\n",
    );
    w(
        "plan-twice.csv",
        b"# plan: paper\n# Plan: adaptive\ntheta_i,theta_r,brdf\n20,20,5\n20,30,4\n20,40,3\n",
    );
    w(
        "k-ok.toml",
        b"k = 2000\nu_k = 0.0\nstandard = \"lambertian:0.99\"\nreference_file = \"ref.csv\"\ndate = \"2026-12-01T18:30:00Z\"\nreadings = 9\n",
    );
    let rgl = std::fs::read(
        crate::util::repo_root().join("host-tool/tests/data/rgl_ilm_l3_37_metallic_rgb.bsdf"),
    )
    .unwrap();
    w("rgl.bsdf", &rgl);
    w("rgl-cut.bsdf", &rgl[..rgl.len() - 1000]);
    // The hand-made spectral material, and copies with its `spectra` field's wavelength
    // count cut to 3 (shapes that disagree) and its first value NaN.
    let spec = std::fs::read(
        crate::util::repo_root().join("host-tool/tests/data/rgl_spectral_handmade.bsdf"),
    )
    .unwrap();
    w("spec.bsdf", &spec);
    // After the name "spectra": rank (2 bytes), type (1), offset (8), 5 sizes (8 each).
    let at = spec.windows(7).position(|n| n == b"spectra").unwrap() + 7;
    let offset = u64::from_le_bytes(spec[at + 3..at + 11].try_into().unwrap()) as usize;
    let mut shapes = spec.clone();
    shapes[at + 11 + 16..at + 11 + 24].copy_from_slice(&3u64.to_le_bytes());
    w("spec-shapes.bsdf", &shapes);
    let mut nan = spec.clone();
    nan[offset..offset + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    w("spec-nan.bsdf", &nan);
    // Its 9 wavelengths moved to 500..900 nm: too little of the CIE ybar for Y.
    let at = spec.windows(11).position(|n| n == b"wavelengths").unwrap() + 11;
    let offset = u64::from_le_bytes(spec[at + 3..at + 11].try_into().unwrap()) as usize;
    let mut narrow = spec.clone();
    for k in 0..9 {
        let nm = 500.0f32 + 50.0 * k as f32;
        narrow[offset + 4 * k..offset + 4 * k + 4].copy_from_slice(&nm.to_le_bytes());
    }
    w("spec-narrow.bsdf", &narrow);
    w(
        "astm-count.astm",
        b"NUM_POINTS 3\nVARS theta_i,phi_i,theta_s,phi_s,BRDF\n0.5,0,0.5,3.14159,1\n0.5,0,0.4,3.14159,1\n",
    );
    w(
        "astm-rgb.astm",
        b"VARS theta_i,phi_i,theta_s,phi_s,R,G,B\n0.5,0,0.5,3.14159,1,2,3\n",
    );
    w(
        "astm-nan.astm",
        b"VARS theta_i,phi_i,theta_s,phi_s,BRDF\n0.5,0,0.5,3.14159,nan\n",
    );
    w(
        "astm-btdf.astm",
        b"VARS theta_i,phi_i,theta_s,phi_s,BRDF\n0.5,0,2.5,3.14159,1\n",
    );
    w("table-nan.csv", b"AOI,AOS,BRDF\n20,20,5\n20,30,NaN\n");
    w("table-short.csv", b"AOI,AOS,BRDF\n20,20,5\n20,30\n");
    w("table-theta.csv", b"AOI,AOS,BRDF\n20,20,5\n95,30,1\n");
    w("fit-nan.csv", b"theta_i,theta_r,brdf\n10,0,1\n10,5,nan\n");
    w("fit-bin.csv", b"\x00\x01\x02\xff\n");
    w("fit-few.csv", b"theta_i,theta_r,brdf\n10,0,1\n10,5,2\n");
    w(
        "fit-neg.csv",
        b"theta_i,theta_r,brdf\n10,0,1\n10,5,-2\n10,9,3\n",
    );
    w(
        "fit-range.csv",
        b"theta_i,theta_r,brdf\n10,0,1\n10,95,2\n10,9,3\n",
    );
    // Issue 16: inputs that were silently misread.
    w(
        "radians.csv",
        b"# units: radians\ntheta_i,theta_r,brdf\n0.3,0.3,5\n",
    );
    w("seq.csv", b"theta_i,theta_r,brdf,seq\n20,20,5,4294967396\n");
    w("dup.csv", b"theta_i,theta_r,brdf,brdf\n20,20,5,6\n");
    w("tiny.csv", b"theta_i,theta_r,brdf\n20,20,5\n20,30,1e-300\n");
    w("denormal.csv", b"theta_i,theta_r,brdf\n20,20,1e-320\n");
    w("big.csv", b"theta_i,theta_r,brdf\n20,20,1e308\n");
    let mut field = b"theta_i,theta_r,brdf\n20,20,\x00\x1b[2J".to_vec();
    field.extend(std::iter::repeat_n(b'x', 10_000_000));
    field.push(b'\n');
    w("field.csv", &field);
    let mut many = String::from("theta_i,theta_r,brdf\n");
    for k in 0..91 {
        let ti = k as f64 * 0.5;
        for tr in [-40, 0, 40] {
            many.push_str(&format!(
                "{ti},{tr},{}\n",
                1.0 + (tr as f64 - ti).abs() / 100.0
            ));
        }
    }
    w("many.csv", many.as_bytes());
    w(
        "new.toml",
        b"incidences = [20]\ndetector = { start = -80, stop = 80, step = 10 }\n",
    );
    // A measured sweep to replay (one incidence, theta_r -10..10) and a plan beyond it.
    w(
        "replay-src.csv",
        b"theta_i,theta_r,brdf\n30,-10,5\n30,10,4\n",
    );
    w(
        "replay-span.toml",
        b"incidences = [30]\ndetector = { start = -20, stop = 20, step = 10 }\n",
    );
    let sim = simulated(&d, "fe-0.115");
    // A capture file whose status line was shortened by hand.
    let text = std::fs::read_to_string(&sim).unwrap();
    let status = text.lines().nth(1).unwrap().to_string();
    w(
        "shortened.csv",
        text.replacen(&status, "# status: running", 1).as_bytes(),
    );
    // Issue 41 item 6: rows a resume must not continue: seq 0 at plan point 1's
    // angles (two plans mixed), and a seq beyond the plan.
    let first_row = text
        .lines()
        .skip_while(|l| !l.starts_with("theta_i"))
        .nth(1)
        .unwrap();
    let moved = first_row.replacen("0,-80,", "0,-70,", 1);
    assert_ne!(moved, first_row);
    w(
        "otherpoint.csv",
        text.replacen(first_row, &moved, 1).as_bytes(),
    );
    w(
        "beyond.csv",
        format!("{text}0,-80,95,0.4,4,153,12\n").as_bytes(),
    );
    w(
        "hugestd.csv",
        b"theta_i,theta_r,brdf,std\n20,20,5,1e300\n20,30,6,0.1\n20,40,7,0.1\n",
    );
    std::os::unix::fs::symlink(d.join("exists.csv"), d.join("link.csv")).unwrap();
    w(
        "seqdup.csv",
        b"theta_i,theta_r,brdf,seq\n20,20,5,0\n20,30,6,0\n",
    );
    w("unclosed.toml", b"incidences = [20\n");
    let mut big = b"incidences = [20]\n".to_vec();
    big.extend(std::iter::repeat_n(b'#', 64 << 10));
    w("bigplan.toml", &big);
    // Held locked by the test (a capture writing it).
    w("locked.csv", text.as_bytes());
    accepted_fixtures(&d, &text);
    d
}

/// Files `fit` reads as meant (see [`ACCEPTED`]), made from a simulated capture's `text`.
fn accepted_fixtures(d: &Path, text: &str) {
    let w = |name: &str, bytes: &[u8]| std::fs::write(d.join(name), bytes).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let status = lines[1];
    let with_status = |word: &str, keep: usize| {
        let mut t = lines[..keep].join("\n").replacen(
            status,
            &status.replacen("complete", &format!("{word:<8}"), 1),
            1,
        );
        t.push('\n');
        t
    };
    let mut bom = b"\xef\xbb\xbf".to_vec();
    bom.extend(text.as_bytes());
    w("ok-bom.csv", &bom);
    w("ok-cr.csv", text.replace('\n', "\r").as_bytes());
    w("ok-crlf.csv", text.replace('\n', "\r\n").as_bytes());
    // RFC 4180 quoting: quoted names and numbers, a quoted comma in an extra column.
    w(
        "ok-quoted.csv",
        b"\"theta_i\",\"theta_r\",\"brdf\",note\n\"20\",\"20\",5,\"a, b\"\n20,30,\"4\",\"say \"\"x\"\"\"\n\n20,40,3,\n",
    );
    // Another tool's file whose last row lacks its newline: read.
    w(
        "ok-nonl.csv",
        b"theta_i,theta_r,brdf\n20,20,5\n20,30,4\n20,40,3",
    );
    // A capture cut while writing its last row: that row is left out, and said.
    let cut = with_status("running", lines.len());
    w("ok-cut.csv", &cut.as_bytes()[..cut.len() - 4]);
    w(
        "ok-failed.csv",
        with_status("failed", lines.len() - 53).as_bytes(),
    );
    w(
        "ok-complete-missing.csv",
        with_status("complete", lines.len() - 3).as_bytes(),
    );
    w(
        "ok-repeat.csv",
        b"theta_i,theta_r,brdf\n20,20,5\n20,30,4\n20,20,50\n",
    );
    w(
        "ok-big.csv",
        b"theta_i,theta_r,brdf\n20,20,1e30\n20,30,4\n20,40,1e-30\n",
    );
    // Another tool's delimiters (sniffed) and column names in another case.
    w(
        "ok-semicolon.csv",
        b"Theta_i;Theta_r;BRDF\n20;20;5\n20;30;4\n20;40;3\n",
    );
    w(
        "ok-tab.csv",
        b"# brdf: relative\nTHETA_I\tTHETA_R\tBrdf\n20\t20\t5\n20\t30\t4\n20\t40\t3\n",
    );
    // A symlink where a predictable temporary name would be: never written through.
    std::os::unix::fs::symlink(d.join("exists.csv"), d.join("out.json.tmp")).unwrap();
}

const CASES: &[Case] = &[
    // eval: the model's own checks, in the order the user meets them
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "nan",
            "--theta-r",
            "0",
        ],
        2,
        "theta_i must be a finite number",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "20",
            "--theta-r",
            "0,nan",
        ],
        2,
        "not a finite number",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "20",
            "--theta-r",
            "-80:95:5",
        ],
        2,
        "theta_r = 95 is outside [-90, 90]",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "20",
            "--theta-r",
            "-90.5",
        ],
        2,
        "theta_r = -90.5 is outside",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "-1",
            "--theta-r",
            "0",
        ],
        2,
        "theta_i = -1 is outside [0, 90]",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "90.01",
            "--theta-r",
            "0",
        ],
        2,
        "theta_i = 90.01 is outside",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "20",
            "--theta-r",
            "0",
            "--sigma",
            "0",
        ],
        2,
        "sigma must be > 0",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "20",
            "--theta-r",
            "0",
            "--sigma",
            "-1",
        ],
        2,
        "sigma must be > 0",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "20",
            "--theta-r",
            "0",
            "--kdd",
            "inf",
        ],
        2,
        "k_dd must be a finite number",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "20",
            "--theta-r",
            "0",
            "--kid",
            "-3",
        ],
        2,
        "k_id must be >= 0",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "20",
            "--theta-r",
            "0",
            "--sigma-m",
            "0",
        ],
        2,
        "sigma_m must be > 0",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "20",
            "--theta-r",
            "0",
            "--kd",
            "3",
        ],
        2,
        "--kd belongs to --model ts",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "20",
            "--theta-r",
            "0:10",
        ],
        2,
        "neither a number nor start:stop:step",
    ),
    case(
        &["eval", "--material", "fe-0.115", "--theta-i", "20"],
        2,
        "--theta-r",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "20",
            "--theta-r",
            "0",
            "--precision",
            "f16",
        ],
        2,
        "f16",
    ),
    case(
        &[
            "eval",
            "--ks",
            "inf",
            "--sigma",
            "0.1",
            "--theta-i",
            "20",
            "--theta-r",
            "0",
        ],
        2,
        "k_s must be a finite number",
    ),
    case(
        &[
            "eval",
            "--material",
            "gold",
            "--theta-i",
            "20",
            "--theta-r",
            "0",
        ],
        2,
        "unknown preset",
    ),
    case(
        &["eval", "--theta-i", "20", "--theta-r", "0"],
        2,
        "--material",
    ),
    case(
        &["eval", "--ks", "3", "--theta-i", "20", "--theta-r", "0"],
        2,
        "--sigma",
    ),
    case(
        &[
            "eval",
            "--model",
            "ts",
            "--material",
            "fe-0.115",
            "--kdd",
            "3",
            "--theta-i",
            "20",
            "--theta-r",
            "0",
        ],
        2,
        "--model ts uses --kd",
    ),
    // metadata a fit reads, given twice and not the same
    case(
        &["fit", "{d}/brdf-twice.csv"],
        2,
        "'# brdf:' is given twice, 'relative' and '1/sr': keep the one that is meant",
    ),
    // import merl: special files and grids too large as a whole
    out(
        &["import", "merl", "{d}/pipe.binary", "--out", "{d}/m.csv"],
        2,
        "pipe.binary: not a regular file",
        "m.csv",
    ),
    out(
        &[
            "import",
            "merl",
            "{d}/gold.binary",
            "--theta-i",
            "0:80:0.01",
            "--theta-r=-89:89:0.1",
            "--out",
            "{d}/m.csv",
        ],
        2,
        "8001 incidences x 1781 detector angles = 14249781 rows, more than 1000000",
        "m.csv",
    ),
    // import astm: the header, then each row
    out(
        &["import", "astm", "{d}/fit-aoi.csv", "--out", "{d}/a.csv"],
        2,
        "no VARS line: not an ASTM E1392 table",
        "a.csv",
    ),
    out(
        &[
            "import",
            "astm",
            "{d}/astm-count.astm",
            "--out",
            "{d}/a.csv",
        ],
        2,
        "astm-count.astm:1: NUM_POINTS 3 but the file holds 2 rows",
        "a.csv",
    ),
    out(
        &["import", "astm", "{d}/astm-rgb.astm", "--out", "{d}/a.csv"],
        2,
        "3 channels (R, G, B): choose one with --channel",
        "a.csv",
    ),
    out(
        &[
            "import",
            "astm",
            "{d}/astm-rgb.astm",
            "--out",
            "{d}/a.csv",
            "--channel",
            "Y",
        ],
        2,
        "no channel 'Y' in VARS (it names R, G, B)",
        "a.csv",
    ),
    out(
        &["import", "astm", "{d}/astm-nan.astm", "--out", "{d}/a.csv"],
        2,
        "astm-nan.astm:2: BRDF 'nan' is not a finite number",
        "a.csv",
    ),
    out(
        &["import", "astm", "{d}/astm-btdf.astm", "--out", "{d}/a.csv"],
        2,
        "theta_s 2.5 rad is outside [0, pi/2]",
        "a.csv",
    ),
    out(
        &["import", "astm", "/dev/zero", "--out", "{d}/a.csv"],
        2,
        "not a regular file",
        "a.csv",
    ),
    // the 1/sr gate: a MERL table of a relative-unit fit needs a scale (issue #37)
    out(
        &["fit", "{d}/fe-0.115.csv", "--export", "merl={d}/fe.binary"],
        2,
        "fe.binary: a merl file holds the BRDF in 1/sr but the fit is in relative units (the instrument's): give --scale S",
        "fe.binary",
    ),
    out(
        &[
            "fit",
            "{d}/ok-tab.csv",
            "--export",
            "merl={d}/fe.binary",
            "--scale",
            "0",
        ],
        2,
        "the scale is 1/sr per relative unit, a finite number above 0",
        "fe.binary",
    ),
    out(
        &["fit", "{d}/fe-0.115.csv", "--export", "zemax={d}/fe.zmx"],
        2,
        "fe.zmx: a zemax file holds the BRDF in 1/sr but the fit is in relative units",
        "fe.zmx",
    ),
    out(
        &["fit", "{d}/fe-0.115.csv", "--export", "astm={d}/fe.astm"],
        2,
        "fe.astm: a astm file holds the BRDF in 1/sr but the fit is in relative units",
        "fe.astm",
    ),
    case(
        &["fit", "{d}/fe-0.115.csv", "--scale", "0.002"],
        2,
        "--scale S converts the exports to 1/sr: give --export FORMAT=PATH too",
    ),
    out(
        &[
            "fit",
            "{d}/persr.csv",
            "--export",
            "merl={d}/fe.binary",
            "--scale",
            "0.002",
        ],
        2,
        "--scale 0.002: the fit is already in 1/sr",
        "fe.binary",
    ),
    case(
        &[
            "fit",
            "{d}/fe-0.115.csv",
            "{d}/ok-tab.csv",
            "--scale",
            "0.002",
        ],
        2,
        "--plot, --export and --scale take one sweep file",
    ),
    // import rgl: the tensor file, then the grid
    out(
        &["import", "rgl", "{d}/fit-aoi.csv", "--out", "{d}/r.csv"],
        2,
        "not an RGL tensor file",
        "r.csv",
    ),
    out(
        &["import", "rgl", "{d}/empty.csv", "--out", "{d}/r.csv"],
        2,
        "cut short in the header",
        "r.csv",
    ),
    out(
        &["import", "rgl", "/dev/zero", "--out", "{d}/r.csv"],
        2,
        "not a regular file",
        "r.csv",
    ),
    out(
        &[
            "import",
            "rgl",
            "{d}/rgl.bsdf",
            "--out",
            "{d}/r.csv",
            "--theta-i",
            "95",
        ],
        2,
        "--theta-i 95: an incidence lies in [0, 90) degrees",
        "r.csv",
    ),
    out(
        &[
            "import",
            "rgl",
            "{d}/rgl.bsdf",
            "--out",
            "{d}/r.csv",
            "--theta-i",
            "0:89:0.0001",
            "--theta-r=-90:90:0.001",
        ],
        2,
        "more than 1000000: choose coarser",
        "r.csv",
    ),
    out(
        &["import", "rgl", "{d}/rgl-cut.bsdf", "--out", "{d}/r.csv"],
        2,
        "does not fit in the file",
        "r.csv",
    ),
    // import rgl, spectral files: the fields, then the wavelength or channel asked for
    out(
        &[
            "import",
            "rgl",
            "{d}/spec-shapes.bsdf",
            "--out",
            "{d}/r.csv",
        ],
        2,
        "a spectral file whose fields do not match",
        "r.csv",
    ),
    out(
        &["import", "rgl", "{d}/spec-nan.bsdf", "--out", "{d}/r.csv"],
        2,
        "field 'spectra' holds a value that is not finite",
        "r.csv",
    ),
    out(
        &[
            "import",
            "rgl",
            "{d}/spec.bsdf",
            "--out",
            "{d}/r.csv",
            "--wavelength",
            "1000",
        ],
        2,
        "--wavelength 1000: outside the file's wavelengths 380..780 nm",
        "r.csv",
    ),
    out(
        &[
            "import",
            "rgl",
            "{d}/spec-narrow.bsdf",
            "--out",
            "{d}/r.csv",
        ],
        2,
        "--channel y: the file's wavelengths 500..900 nm span 93.2 % of the CIE 1931 ybar",
        "r.csv",
    ),
    out(
        &[
            "import",
            "rgl",
            "{d}/spec.bsdf",
            "--out",
            "{d}/r.csv",
            "--channel",
            "r",
        ],
        2,
        "a spectral file (380..780 nm) has no r, g, b",
        "r.csv",
    ),
    out(
        &[
            "import",
            "rgl",
            "{d}/rgl.bsdf",
            "--out",
            "{d}/r.csv",
            "--wavelength",
            "550",
        ],
        2,
        "an RGB file has channels r, g, b and y, not wavelengths",
        "r.csv",
    ),
    // import table: the column mapping, then each row
    out(
        &[
            "import",
            "table",
            "{d}/fit-aoi.csv",
            "--out",
            "{d}/t.csv",
            "--columns",
            "theta_i=AOI,theta_r=AOS,brdf=Value",
            "--brdf",
            "1/sr",
        ],
        2,
        "no column 'Value' for brdf: the header row holds 3 column(s) separated by ';': 'AOI' 'AOS' 'BRDF'",
        "t.csv",
    ),
    out(
        &[
            "import",
            "table",
            "{d}/fit-aoi.csv",
            "--out",
            "{d}/t.csv",
            "--columns",
            "theta_i=AOI,theta_r=AOS",
            "--brdf",
            "1/sr",
        ],
        2,
        "--columns needs theta_i=..., theta_r=... and brdf=...",
        "t.csv",
    ),
    out(
        &[
            "import",
            "table",
            "{d}/fit-aoi.csv",
            "--out",
            "{d}/t.csv",
            "--columns",
            "theta_i=AOI,theta_r=AOS,brdf=BRDF",
        ],
        2,
        "--brdf",
        "t.csv",
    ),
    out(
        &[
            "import",
            "table",
            "{d}/fit-aoi.csv",
            "--out",
            "{d}/t.csv",
            "--columns",
            "theta_i=AOI,theta_r=AOS,brdf=BRDF",
            "--brdf",
            "W",
        ],
        2,
        "brdf units 'W'",
        "t.csv",
    ),
    out(
        &[
            "import",
            "table",
            "{d}/table-comma.csv",
            "--out",
            "{d}/t.csv",
            "--columns",
            "theta_i=AOI,theta_r=AOS,brdf=BRDF",
            "--brdf",
            "1/sr",
        ],
        2,
        "table-comma.csv:2: brdf '0,5' is not a finite number (a decimal comma? give --decimal-comma)",
        "t.csv",
    ),
    out(
        &[
            "import",
            "table",
            "{d}/table-std.csv",
            "--out",
            "{d}/t.csv",
            "--columns",
            "theta_i=AOI,theta_r=AOS,brdf=BRDF,std=SIGMA",
            "--brdf",
            "1/sr",
        ],
        2,
        "table-std.csv:3: std -0.01 is negative: a standard deviation is >= 0",
        "t.csv",
    ),
    out(
        &[
            "import",
            "table",
            "{d}/table-nan.csv",
            "--out",
            "{d}/t.csv",
            "--columns",
            "theta_i=AOI,theta_r=AOS,brdf=BRDF",
            "--brdf",
            "1/sr",
            "--decimal-comma",
        ],
        2,
        "--decimal-comma with ',' as the delimiter",
        "t.csv",
    ),
    out(
        &[
            "import",
            "table",
            "{d}/table-nan.csv",
            "--out",
            "{d}/t.csv",
            "--columns",
            "theta_i=AOI,theta_r=AOS,brdf=BRDF",
            "--brdf",
            "1/sr",
        ],
        2,
        "table-nan.csv:3: brdf 'NaN' is not a finite number",
        "t.csv",
    ),
    out(
        &[
            "import",
            "table",
            "{d}/table-short.csv",
            "--out",
            "{d}/t.csv",
            "--columns",
            "theta_i=AOI,theta_r=AOS,brdf=BRDF",
            "--brdf",
            "1/sr",
        ],
        2,
        "table-short.csv:3: 2 field(s) where the header row has 3",
        "t.csv",
    ),
    out(
        &[
            "import",
            "table",
            "{d}/table-theta.csv",
            "--out",
            "{d}/t.csv",
            "--columns",
            "theta_i=AOI,theta_r=AOS,brdf=BRDF",
            "--brdf",
            "1/sr",
        ],
        2,
        "theta_i 95 degrees is outside [0, 90]",
        "t.csv",
    ),
    out(
        &[
            "import",
            "table",
            "/dev/zero",
            "--out",
            "{d}/t.csv",
            "--columns",
            "theta_i=AOI,theta_r=AOS,brdf=BRDF",
            "--brdf",
            "1/sr",
        ],
        2,
        "not a regular file",
        "t.csv",
    ),
    out(
        &[
            "import",
            "table",
            "{d}/garbage.csv",
            "--out",
            "{d}/t.csv",
            "--columns",
            "theta_i=AOI,theta_r=AOS,brdf=BRDF",
            "--brdf",
            "1/sr",
        ],
        2,
        "not UTF-8 text",
        "t.csv",
    ),
    out(
        &[
            "import",
            "table",
            "{d}/header.csv",
            "--out",
            "{d}/t.csv",
            "--columns",
            "theta_i=1,theta_r=2,brdf=3",
            "--brdf",
            "1/sr",
            "--no-header",
        ],
        2,
        "theta_i 'theta_i' is not a finite number",
        "t.csv",
    ),
    case(
        &[
            "import",
            "table",
            "{d}/fit-aoi.csv",
            "--out",
            "{d}/fit-aoi.csv",
            "--force",
            "--columns",
            "theta_i=AOI,theta_r=AOS,brdf=BRDF",
            "--brdf",
            "1/sr",
        ],
        2,
        "is the input file",
    ),
    // fit: reading the sweep file, then the options
    case(&["fit", "/nonexistent.csv"], 2, "cannot read"),
    case(&["fit", "{d}/empty.csv"], 2, "no readings"),
    case(&["fit", "{d}/fit-cols.csv"], 2, "missing column 'theta_r'"),
    case(
        &["fit", "{d}/fit-aoi.csv"],
        2,
        "3 column(s) separated by ';': 'AOI' 'AOS' 'BRDF'; gonio reads theta_i, theta_r, brdf (any case); for other names use gonio import table",
    ),
    case(&["fit", "{d}/fit-nan.csv"], 2, ":3: brdf 'nan'"),
    case(
        &["fit", "{d}/fit-bin.csv"],
        2,
        "not UTF-8 text: not a sweep file (binary data; a MERL .binary table is read with gonio import merl)",
    ),
    case(
        &["fit", "{d}/gold.binary"],
        2,
        "is a MERL BRDF table (.binary), not a sweep file: import the plane of incidence first, e.g. gonio import merl",
    ),
    case(&["fit", "{d}/fit-few.csv"], 2, "at least 3"),
    // The default objective compares a reading below 0 with its noise floor; log
    // residuals cannot.
    case(
        &["fit", "{d}/fit-neg.csv", "--residual", "log"],
        2,
        "--residual abs take it",
    ),
    case(&["fit", "{d}/fit-range.csv"], 2, "theta_r = 95"),
    case(&["fit", "{d}/fe-0.115.csv", "--fix", "sigma=-1"], 2, "> 0"),
    case(
        &["fit", "{d}/fe-0.115.csv", "--fix", "rho=1"],
        2,
        "unknown parameter",
    ),
    case(
        &["fit", "{d}/fe-0.115.csv", "--loss", "cauchy:0"],
        2,
        "scale",
    ),
    case(&["fit", "{d}/fe-0.115.csv", "--loss", "tukey"], 2, "--loss"),
    case(&["fit", "{d}/fe-0.115.csv", "--models", "four"], 2, "four"),
    case(
        &["fit", "{d}/fe-0.115.csv", "--floor", "-1"],
        2,
        "floor '-1': expected auto or a finite value >= 0",
    ),
    case(
        &["fit", "{d}/fe-0.115.csv", "--floor", "nan"],
        2,
        "floor 'nan': expected auto",
    ),
    case(
        &["fit", "{d}/fe-0.115.csv", "--floor", "often"],
        2,
        "floor 'often': expected auto",
    ),
    case(
        &["fit", "{d}/fe-0.115.csv", "--fix", "sigma=50"],
        2,
        "the fit's bounds for it",
    ),
    // The Fresnel member's n and k (issue 36): a metal gonio has no table for, a
    // wavelength outside the table, --fresnel without a :fresnel member, both ways of
    // holding n, k at once, a negative k, and eval, which has no n and k options.
    case(
        &[
            "fit",
            "{d}/fe-0.115.csv",
            "--models",
            "specular:fresnel+ideal-diffuse",
            "--fresnel",
            "pt@532",
        ],
        2,
        "--fresnel 'pt@532': unknown metal (known: al, cu, fe, au, ag)",
    ),
    case(
        &[
            "fit",
            "{d}/fe-0.115.csv",
            "--models",
            "specular:fresnel+ideal-diffuse",
            "--fresnel",
            "al@300",
        ],
        2,
        "wavelength outside the metal's table",
    ),
    case(
        &["fit", "{d}/fe-0.115.csv", "--fresnel", "al@532"],
        2,
        "name a member with one in --models",
    ),
    case(
        &[
            "fit",
            "{d}/fe-0.115.csv",
            "--models",
            "specular:fresnel+ideal-diffuse",
            "--fresnel",
            "al@532",
            "--fix",
            "n=1.2",
        ],
        2,
        "not both",
    ),
    case(
        &["fit", "{d}/fe-0.115.csv", "--fix", "k=-1"],
        2,
        "finite and >= 0",
    ),
    case(
        &[
            "eval",
            "--model",
            "specular:fresnel",
            "--ks",
            "1",
            "--sigma",
            "0.1",
            "--theta-i",
            "30",
            "--theta-r",
            "30",
        ],
        2,
        "no options for a :fresnel lobe",
    ),
    case(
        &["fit", "{d}/fe-0.115.csv", "--checks", "some"],
        2,
        "[possible values: all, selected, none]",
    ),
    // eval
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "NaN",
            "--theta-r",
            "0",
        ],
        2,
        "theta_i",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "1e308",
            "--theta-r",
            "0",
        ],
        2,
        "theta_i",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "-5",
            "--theta-r",
            "0",
        ],
        2,
        "theta_i",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "20",
            "--theta-r",
            "NaN",
        ],
        2,
        "theta-r",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "20",
            "--theta-r",
            "0:80:0",
        ],
        2,
        "step",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "20",
            "--theta-r",
            "-90:90:1e-9",
        ],
        2,
        "theta-r",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "20",
            "--theta-r",
            "",
        ],
        2,
        "theta-r",
    ),
    case(
        &[
            "eval",
            "--material",
            "unobtainium",
            "--theta-i",
            "20",
            "--theta-r",
            "0",
        ],
        2,
        "unobtainium",
    ),
    case(
        &[
            "eval",
            "--ks",
            "NaN",
            "--sigma",
            "0.1",
            "--theta-i",
            "20",
            "--theta-r",
            "0",
        ],
        2,
        "k",
    ),
    case(
        &[
            "eval",
            "--ks",
            "1",
            "--sigma",
            "-1",
            "--theta-i",
            "20",
            "--theta-r",
            "0",
        ],
        2,
        "sigma",
    ),
    case(
        &[
            "eval",
            "--ks",
            "1e999",
            "--sigma",
            "0.1",
            "--theta-i",
            "20",
            "--theta-r",
            "0",
        ],
        2,
        "k",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "twenty",
            "--theta-r",
            "0",
        ],
        2,
        "theta-i",
    ),
    // fit
    case(&["fit", "{d}/missing.csv"], 2, "missing.csv"),
    case(&["fit", "{d}/empty.csv"], 2, "empty.csv"),
    case(&["fit", "{d}/garbage.csv"], 2, "garbage.csv"),
    case(&["fit", "{d}/nocols.csv"], 2, "column"),
    case(&["fit", "{d}/header.csv"], 2, "no readings"),
    case(&["fit", "{d}/nan.csv"], 2, "nan.csv:2"),
    case(&["fit", "{d}/huge.csv"], 2, "huge.csv:2"),
    case(&["fit", "{d}/negative.csv"], 2, "negative.csv"),
    case(&["fit", "{d}/angles.csv"], 2, "angles.csv"),
    case(&["fit", "{d}/short.csv"], 2, "short.csv:2"),
    case(
        &["fit", "{d}/rel.csv", "--instrument", "{d}/k-huge.toml"],
        2,
        "k-huge.toml: instrument: k = 1e300 is outside 1e-15..1e15",
    ),
    out(
        &[
            "convert",
            "{d}/rel.csv",
            "--instrument",
            "{d}/k-tiny.toml",
            "--out",
            "{d}/conv.csv",
        ],
        2,
        "k-tiny.toml: instrument: k = 1e-300 is outside 1e-15..1e15",
        "conv.csv",
    ),
    out(
        &[
            "calibrate",
            "{d}/bright-ref.csv",
            "--standard",
            "lambertian:0.99",
            "--out",
            "{d}/bright.toml",
        ],
        2,
        "cannot determine K: instrument: k = 3.1",
        "bright.toml",
    ),
    case(
        &["fit", "{d}/too-many.csv"],
        2,
        "too-many.csv: 2097153 readings: more than one fit takes (2097152",
    ),
    case(&["fit", "{d}/nan.csv", "--loss", "huber:-1"], 2, "loss"),
    case(&["fit", "{d}/nan.csv", "--fix", "sigma=NaN"], 2, "sigma"),
    // capture
    out(
        &[
            "capture",
            "--port",
            "{d}/no-such-port",
            "--out",
            "{d}/c1.csv",
        ],
        1,
        "no-such-port",
        "c1.csv",
    ),
    out(
        &["capture", "--port", "/dev/null", "--out", "{d}/c2.csv"],
        2,
        "cannot open /dev/null: not a serial port (a device that is not a terminal): give the device's port",
        "c2.csv",
    ),
    out(
        &[
            "capture",
            "--port",
            "{d}/no-such-port",
            "--plan",
            "{d}/garbage.toml",
            "--out",
            "{d}/c3.csv",
        ],
        2,
        "garbage.toml",
        "c3.csv",
    ),
    case(&["capture", "--port", "{d}/no-such-port"], 2, "--out"),
    out(
        &[
            "capture",
            "--port",
            "{d}/no-such-port",
            "--resume",
            "--out",
            "{d}/c4.csv",
        ],
        2,
        "c4.csv",
        "c4.csv",
    ),
    // simulate (the same capture code, without hardware)
    // --until: a parameter the fit does not report, a target that is no relative error
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--until",
            "sigmaa:2%",
            "--out",
            "{d}/u1.csv",
        ],
        2,
        "unknown parameter 'sigmaa' (valid: sigma, sigma_haze, sigma_m, k_dd, k_id",
        "u1.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--until",
            "sigma:0%",
            "--out",
            "{d}/u2.csv",
        ],
        2,
        "above 0 and at most 100%",
        "u2.csv",
    ),
    out(
        &[
            "capture",
            "--port",
            "/dev/null",
            "--until",
            "sigma",
            "--out",
            "{d}/u3.csv",
        ],
        2,
        "is not PARAM:REL",
        "u3.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--plan",
            "sequential",
            "--budget",
            "0",
            "--out",
            "{d}/u4.csv",
        ],
        2,
        "a sequential plan takes 1 to",
        "u4.csv",
    ),
    // Issue 51: --meta KEY=VALUE checked as the reader checks it, --role/--of
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--meta",
            "wavelength=632.8 um",
            "--out",
            "{d}/m1.csv",
        ],
        2,
        "wavelength: unit 'um' is not nm",
        "m1.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--meta",
            "colour=red",
            "--out",
            "{d}/m2.csv",
        ],
        2,
        "unknown key 'colour': one of wavelength, polarization",
        "m2.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--meta",
            "wavelenght=532",
            "--out",
            "{d}/m3.csv",
        ],
        2,
        "did you mean wavelength",
        "m3.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--meta",
            "temperature=-300",
            "--out",
            "{d}/m4.csv",
        ],
        2,
        "temperature: -300 is out of range",
        "m4.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--meta",
            "sample=a",
            "--meta",
            "SAMPLE=b",
            "--out",
            "{d}/m5.csv",
        ],
        2,
        "--meta sample: given twice",
        "m5.csv",
    ),
    out(
        &[
            "capture",
            "--port",
            "/dev/null",
            "--meta",
            "date=yesterday",
            "--out",
            "{d}/m6.csv",
        ],
        2,
        "date: 'yesterday' is not an ISO 8601 date",
        "m6.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--meta",
            "role=dark",
            "--out",
            "{d}/m7.csv",
        ],
        2,
        "role: give it with --role",
        "m7.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--role",
            "dark",
            "--out",
            "{d}/m8.csv",
        ],
        2,
        "--of <SWEEP>",
        "m8.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--role",
            "blocked",
            "--of",
            "fe.csv",
            "--out",
            "{d}/m9.csv",
        ],
        2,
        "possible values: dark, signature",
        "m9.csv",
    ),
    out(
        &[
            "capture",
            "--port",
            "/dev/null",
            "--reference",
            "lambertian:0.99",
            "--role",
            "signature",
            "--of",
            "fe.csv",
            "--out",
            "{d}/m10.csv",
        ],
        2,
        "cannot be used with",
        "m10.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--resume",
            "--meta",
            "wavelength=532",
            "--out",
            "{d}/fe-0.115.csv",
        ],
        2,
        "records no wavelength (a resumed file keeps the header it was started with)",
        "fe-0.115.csv",
    ),
    case(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--pty",
            "--meta",
            "operator=x",
        ],
        2,
        "not to --pty",
    ),
    out(
        &[
            "simulate",
            "--replay",
            "{d}/replay-src.csv",
            "--out",
            "{d}/sr1.csv",
        ],
        2,
        "incidence 0 is not in",
        "sr1.csv",
    ),
    out(
        &[
            "simulate",
            "--replay",
            "{d}/replay-src.csv",
            "--plan",
            "{d}/replay-span.toml",
            "--out",
            "{d}/sr2.csv",
        ],
        2,
        "outside",
        "sr2.csv",
    ),
    out(
        &[
            "simulate",
            "--replay",
            "{d}/header.csv",
            "--out",
            "{d}/sr3.csv",
        ],
        2,
        "no reading to replay",
        "sr3.csv",
    ),
    out(
        &[
            "simulate",
            "--replay",
            "{d}/replay-src.csv",
            "--material",
            "fe-0.115",
            "--out",
            "{d}/sr4.csv",
        ],
        2,
        "--material",
        "sr4.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "unobtainium",
            "--out",
            "{d}/s1.csv",
        ],
        2,
        "unobtainium",
        "s1.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--noise",
            "NaN",
            "--out",
            "{d}/s2.csv",
        ],
        2,
        "noise",
        "s2.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--noise",
            "-1",
            "--out",
            "{d}/s3.csv",
        ],
        2,
        "noise",
        "s3.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--samples",
            "0",
            "--out",
            "{d}/s4.csv",
        ],
        2,
        "samples",
        "s4.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--exclude-retro",
            "-1",
            "--out",
            "{d}/s5.csv",
        ],
        2,
        "exclu",
        "s5.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--exclude-retro",
            "NaN",
            "--out",
            "{d}/s6.csv",
        ],
        2,
        "exclu",
        "s6.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--plan",
            "{d}/missing.toml",
            "--out",
            "{d}/s7.csv",
        ],
        2,
        "missing.toml",
        "s7.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--plan",
            "{d}/garbage.toml",
            "--out",
            "{d}/s8.csv",
        ],
        2,
        "garbage.toml",
        "s8.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--plan",
            "{d}/empty.csv",
            "--out",
            "{d}/s9.csv",
        ],
        2,
        "plan",
        "s9.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--plan",
            "{d}/nan.toml",
            "--out",
            "{d}/s10.csv",
        ],
        2,
        "nan.toml",
        "s10.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--plan",
            "{d}/huge.toml",
            "--out",
            "{d}/s11.csv",
        ],
        2,
        "plan",
        "s11.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--plan",
            "{d}/neg.toml",
            "--out",
            "{d}/s12.csv",
        ],
        2,
        "plan",
        "s12.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--plan",
            "{d}/both.toml",
            "--out",
            "{d}/s13.csv",
        ],
        2,
        "both.toml",
        "s13.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--plan",
            "{d}/unknown.toml",
            "--out",
            "{d}/s14.csv",
        ],
        2,
        "samplez",
        "s14.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--plan",
            "adaptive",
            "--out",
            "{d}/s15.csv",
        ],
        2,
        "prior",
        "s15.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--plan",
            "adaptive",
            "--prior",
            "unobtainium",
            "--out",
            "{d}/s16.csv",
        ],
        2,
        "unobtainium",
        "s16.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--plan",
            "adaptive",
            "--prior",
            "fe-0.115",
            "--budget",
            "99999999",
            "--out",
            "{d}/s17.csv",
        ],
        2,
        "budget",
        "s17.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--resume",
            "--out",
            "{d}/s18.csv",
        ],
        2,
        "s18.csv",
        "s18.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--resume",
            "--out",
            "{d}/garbage.csv",
        ],
        2,
        "garbage.csv",
        "garbage.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--resume",
            "--out",
            "{d}/nocols.csv",
        ],
        2,
        "nocols.csv",
        "nocols.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--out",
            "{d}/exists.csv",
        ],
        2,
        "exists",
        "exists.csv",
    ),
    case(
        &["simulate", "--material", "fe-0.115", "--out", "/proc/x.csv"],
        2,
        "cannot write /proc/x.csv: cannot create a file in /proc",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--out",
            "{d}/plainfile/x.csv",
        ],
        2,
        "cannot write {d}/plainfile/x.csv: {d}/plainfile is not a directory",
        "plainfile/x.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--out",
            "{d}/s19.csv",
            "--raw",
            "/proc/x.raw",
        ],
        1,
        "/proc/x.raw",
        "s19.csv",
    ),
    case(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--pty",
            "--speed",
            "NaN",
        ],
        2,
        "speed",
    ),
    case(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--pty",
            "--speed",
            "-1",
        ],
        2,
        "speed",
    ),
    case(&["simulate", "--material", "fe-0.115"], 2, "--out"),
    // info
    case(&["info", "--port", "{d}/no-such-port"], 1, "no-such-port"),
    case(
        &["info", "--port", "/dev/null", "--timeout", "1"],
        2,
        "cannot open /dev/null: not a serial port",
    ),
    case(
        &["info", "--port", "{d}/no-such-port", "--timeout", "-1"],
        2,
        "-1",
    ),
    // ports
    case(&["ports", "--bogus"], 2, "bogus"),
    // flash (a build without the feature refuses all of them the same way)
    flash(&["flash", "{d}/missing.elf"], "missing.elf"),
    flash(&["flash", "{d}/garbage.elf"], "garbage.elf"),
    flash(&["flash", "{d}/empty.elf"], "empty.elf"),
    flash(&["flash", "--probe", "zz:yy", "{d}/garbage.elf"], "probe"),
    // demo
    case(
        &["demo", "--material", "unobtainium", "--dir", "{d}/demo1"],
        2,
        "unobtainium",
    ),
    case(
        &["demo", "--noise", "NaN", "--dir", "{d}/demo2"],
        2,
        "noise",
    ),
    case(
        &["demo", "--samples", "0", "--dir", "{d}/demo3"],
        2,
        "samples",
    ),
    case(
        &["demo", "--dir", "/proc/gonio-demo", "-q"],
        1,
        "/proc/gonio-demo",
    ),
    case(&["demo", "--dir", "{d}/plainfile", "-q"], 1, "plainfile"),
    // Issue 16: outputs go only where the user meant.
    out(
        &[
            "fit",
            "{d}/fe-0.115.csv",
            "--export",
            "csv={d}/fe-0.115.csv",
            "--force",
        ],
        2,
        "is the input file",
        "fe-0.115.csv",
    ),
    case(
        &[
            "fit",
            "{d}/fe-0.115.csv",
            "--export",
            "csv=/dev/null",
            "--force",
        ],
        2,
        "not a regular file",
    ),
    case(
        &["fit", "{d}/fe-0.115.csv", "--export", "json=/dev/stdout"],
        2,
        "not a regular file",
    ),
    out(
        &["fit", "{d}/fe-0.115.csv", "--export", "json={d}/exists.csv"],
        2,
        "use --force",
        "exists.csv",
    ),
    out(
        &[
            "fit",
            "{d}/fe-0.115.csv",
            "--export",
            "json={d}/link.csv",
            "--force",
        ],
        2,
        "symbolic link",
        "exists.csv",
    ),
    case(
        &["fit", "{d}/fe-0.115.csv", "--plot", "{d}/exists.csv"],
        2,
        "directory",
    ),
    case(&["bench", "--plot", "{d}/exists.csv"], 2, "use --force"),
    case(&["bench", "--campaign", "0"], 2, "not in 1..=1000000"),
    case(
        &["bench", "--campaign", "2", "--threads", "1,0"],
        2,
        "not in 1..=4096",
    ),
    out(
        &[
            "capture",
            "--port",
            "/nonexistent/tty",
            "--out",
            "{d}/exists.csv",
            "--raw",
            "{d}/new.raw",
        ],
        2,
        "exists",
        "new.raw",
    ),
    case(
        &[
            "capture",
            "--port",
            "/nonexistent/tty",
            "--out",
            "{d}/x.csv",
            "--raw",
            "/dev/null",
        ],
        2,
        "not a regular file",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--out",
            "{d}/link.csv",
            "--force",
            "-q",
        ],
        2,
        "symbolic link",
        "exists.csv",
    ),
    // Issue 16: resume continues only what the file holds, safely.
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--resume",
            "--out",
            "{d}/fe-0.115.csv",
            "--samples",
            "9",
            "-q",
        ],
        2,
        "captured with samples=4",
        "fe-0.115.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--resume",
            "--out",
            "{d}/fe-0.115.csv",
            "--plan",
            "{d}/new.toml",
            "-q",
        ],
        2,
        "captured with plan 'paper'",
        "fe-0.115.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--resume",
            "--out",
            "{d}/shortened.csv",
            "-q",
        ],
        2,
        "status line was edited",
        "shortened.csv",
    ),
    // Issue 41 item 6: resume checks every row's angles against its plan point.
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--resume",
            "--out",
            "{d}/otherpoint.csv",
            "-q",
        ],
        2,
        "seq 0 is at 0:-70 (plan point 1's angles), but plan point 0 is 0:-80",
        "otherpoint.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--resume",
            "--out",
            "{d}/beyond.csv",
            "-q",
        ],
        2,
        "seq 153 (at 0:-80) is beyond the plan's 153 points",
        "beyond.csv",
    ),
    // Issue 41 item 6: what no writer writes, no reader reads.
    case(&["fit", "{d}/hugestd.csv"], 2, "std 1e300"),
    // Issue 16: silently-wrong inputs are refused, naming line and value.
    case(&["fit", "{d}/radians.csv"], 2, "degrees only"),
    case(&["fit", "{d}/seq.csv"], 2, "seq 4294967396 is out of range"),
    case(
        &["fit", "{d}/dup.csv"],
        2,
        "column 'brdf' appears more than once",
    ),
    case(&["fit", "{d}/tiny.csv"], 2, "tiny.csv:3: brdf 1e-300"),
    case(
        &["fit", "{d}/denormal.csv"],
        2,
        "denormal.csv:2: brdf 1e-320",
    ),
    case(&["fit", "{d}/big.csv"], 2, "brdf 1e308"),
    case(&["fit", "{d}/field.csv"], 2, "'\\0\\u{1b}[2Jxxx"),
    case(
        &["fit", "{d}/many.csv", "--plot", "{d}/many"],
        2,
        "at most 90 incidences",
    ),
    // Issue 16: bounded inputs.
    case(&["fit", "/dev/zero"], 2, "not a regular file"),
    case(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--plan",
            "/dev/zero",
            "--out",
            "{d}/z.csv",
        ],
        2,
        "plan /dev/zero",
    ),
    case(
        &[
            "info",
            "--port",
            "/nonexistent/tty",
            "--timeout",
            "9223372036854775807",
        ],
        2,
        "1..=3600",
    ),
    case(
        &[
            "capture",
            "--port",
            "/nonexistent/tty",
            "--out",
            "{d}/r.csv",
            "--reconnect",
            "18446744073709551615",
        ],
        2,
        "0..=86400",
    ),
    case(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--pty",
            "--speed",
            "1e-300",
        ],
        2,
        "not a speed factor from 0.001",
    ),
    case(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--plan",
            "adaptive",
            "--prior",
            "fe-0.115",
            "--budget",
            "17",
            "--out",
            "{d}/b.csv",
        ],
        2,
        "too few readings",
    ),
    // Issue 16, second part: every item of the issue not above.
    case(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--resume",
            "--out",
            "{d}/locked.csv",
            "-q",
        ],
        2,
        "being written by another capture",
    ),
    // Issue 50 case 4: --raw takes the lock as --out does, and never appends to a sweep.
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--raw",
            "{d}/locked.csv",
            "--out",
            "{d}/raw-out.csv",
            "-q",
        ],
        2,
        "--raw {d}/locked.csv is being written by another capture",
        "locked.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--raw",
            "{d}/rel.csv",
            "--out",
            "{d}/raw-out.csv",
            "-q",
        ],
        2,
        "holds a sweep file",
        "rel.csv",
    ),
    // Issue 50 cases 2 and 3: rows by header name, # keys in any case, no duplicates.
    case(
        &["fit", "{d}/comma-row.csv"],
        2,
        "comma-row.csv:2: 5 field(s) where the header row has 4",
    ),
    out(
        &[
            "import",
            "table",
            "{d}/comma-row.csv",
            "--out",
            "{d}/comma-out.csv",
            "--columns",
            "theta_i=theta_i,theta_r=theta_r,brdf=brdf",
            "--brdf",
            "1/sr",
        ],
        2,
        "5 field(s) where the header row has 4",
        "comma-out.csv",
    ),
    case(
        &[
            "fit",
            "{d}/upper-persr.csv",
            "--instrument",
            "{d}/k-ok.toml",
        ],
        2,
        "already holds brdf in 1/sr",
    ),
    case(
        &["fit", "{d}/upper-rad.csv"],
        2,
        "units 'radians': gonio reads angles in degrees only",
    ),
    case(
        &["fit", "{d}/plan-twice.csv"],
        2,
        "'# plan:' is given twice, 'paper' and 'adaptive'",
    ),
    out(
        &[
            "simulate",
            "--material",
            "cu-0.070",
            "--resume",
            "--out",
            "{d}/fe-0.115.csv",
            "-q",
        ],
        2,
        "holds readings of 'simulated fe-0.115 noise=0.005', not 'simulated cu-0.070",
        "fe-0.115.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--noise",
            "0.02",
            "--resume",
            "--out",
            "{d}/fe-0.115.csv",
            "-q",
        ],
        2,
        "noise=0.02",
        "fe-0.115.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--resume",
            "--out",
            "{d}/fe-0.115.csv",
            "--exclude-retro",
            "5",
            "-q",
        ],
        2,
        "captured with exclude_retro=0",
        "fe-0.115.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--resume",
            "--out",
            "{d}/fe-0.115.csv",
            "--dark",
            "-q",
        ],
        2,
        "captured with dark=false",
        "fe-0.115.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--resume",
            "--out",
            "{d}/fe-0.115.csv",
            "--settle",
            "70",
            "-q",
        ],
        2,
        "captured with settle_ms=50",
        "fe-0.115.csv",
    ),
    case(
        &["fit", "{d}/seqdup.csv"],
        2,
        "seqdup.csv:3: seq 0 was already read on line 2",
    ),
    case(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--plan",
            "{d}/bigplan.toml",
            "--out",
            "{d}/p.csv",
        ],
        2,
        "larger than 64 KiB",
    ),
    case(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--plan",
            "{d}/unclosed.toml",
            "--out",
            "{d}/p.csv",
        ],
        2,
        "unclosed.toml",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "30",
            "--theta-r",
            "30",
            "--precision",
            "f32",
            "--kdd",
            "1e300",
        ],
        2,
        "--kdd 1e300 overflows f32",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "30",
            "--theta-r",
            "30",
            "--precision",
            "f32",
            "--sigma",
            "1e-40",
        ],
        2,
        "--sigma 1e-40 underflows f32",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "30",
            "--theta-r",
            "30",
            "--sigma",
            "1e300",
        ],
        2,
        "sigma = 1e300 is too extreme",
    ),
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "30",
            "--theta-r",
            "30",
            "--kdd",
            "-1e300",
        ],
        2,
        "k_dd must be >= 0 (got -1e300)",
    ),
    case(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--noise",
            "1e30",
            "--out",
            "{d}/n.csv",
        ],
        2,
        "(got 1e30)",
    ),
    case(
        &["fit", "{d}/fe-0.115.csv", "--models", "{long}"],
        2,
        "invalid value 'xxx",
    ),
    // Issue 42: each message names the thing and says what to do.
    out(
        &["capture", "--port", "{d}/empty.csv", "--out", "{d}/c42.csv"],
        2,
        "empty.csv: not a serial port (a regular file)",
        "c42.csv",
    ),
    out(
        &["capture", "--port", "{pty}", "--out", "{d}/c43.csv"],
        1,
        "nothing answered on /dev/pts/",
        "c43.csv",
    ),
    case(
        &["info", "--port", "{pty}", "--timeout", "1"],
        1,
        "within 1 s: no gonio device there, or its firmware is not running; check the port (gonio ports",
    ),
    out(
        &[
            "capture",
            "--port",
            "{d}/no-such-port",
            "--out",
            "{d}/nodir/c44.csv",
        ],
        2,
        "the directory {d}/nodir does not exist (create it with mkdir -p",
        "nodir/c44.csv",
    ),
    out(
        &[
            "simulate",
            "--material",
            "fe-0.115",
            "--out",
            "{d}/nodir/s44.csv",
        ],
        2,
        "cannot write {d}/nodir/s44.csv: the directory {d}/nodir does not exist",
        "nodir/s44.csv",
    ),
    out(
        &[
            "fit",
            "{d}/fe-0.115.csv",
            "--export",
            "json={d}/nodir/f44.json",
        ],
        2,
        "the directory {d}/nodir does not exist",
        "nodir/f44.json",
    ),
    // A warning, not a refusal: the evaluation runs, one line says what looks wrong.
    case(
        &[
            "eval",
            "--material",
            "fe-0.115",
            "--theta-i",
            "0.35",
            "--theta-r",
            "-1.2:1.2:0.6",
        ],
        0,
        "warning: every angle in --theta-i and --theta-r is within 1.200: are they radians? gonio reads degrees",
    ),
    // no subcommand, unknown subcommand
    case(&[], 2, "missing subcommand"),
    case(&["frobnicate"], 2, "frobnicate"),
];

/// Longest error line any case may print (bytes).
const MAX_LINE: usize = 1000;

/// A 100,000-character value with control bytes (argv cannot hold NUL; clap's
/// rendering drops the escape sequences, the line must still be bounded) (`{long}` in a case's arguments).
fn long_value() -> String {
    let mut v = String::from("\x1b[2J\x07");
    v.push_str(&"x".repeat(100_000));
    v
}

/// A terminal nothing answers on (`{pty}` in a case's arguments): the slave of a
/// pseudo-terminal whose master is read and discarded, so gonio's pings never fill it.
fn silent_port() -> &'static str {
    static PORT: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    PORT.get_or_init(|| {
        let pty = nix::pty::openpty(None, None).expect("a pseudo-terminal");
        let name = std::fs::read_link(format!("/proc/self/fd/{}", pty.slave))
            .expect("the slave's path")
            .to_string_lossy()
            .into_owned();
        // Closing the slave here would hang up the line for gonio's opens: it stays
        // open (and the master drained) for the whole test binary.
        let master = pty.master;
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while nix::unistd::read(master, &mut buf).is_ok_and(|n| n > 0) {}
        });
        name
    })
}

fn run(d: &Path, c: &Case) {
    let args: Vec<String> = c
        .args
        .iter()
        .map(|a| {
            a.replace("{d}", d.to_str().unwrap())
                .replace("{long}", &long_value())
                .replace("{pty}", silent_port())
        })
        .collect();
    let before = c.no_output.and_then(|p| std::fs::read(d.join(p)).ok());
    let out: Run = gonio_command()
        .args(&args)
        .current_dir(d)
        .output()
        .unwrap()
        .into();
    let err = &out.stderr;
    let ctx = format!("gonio {}", args.join(" "));
    let says = c.says.replace("{d}", d.to_str().unwrap());
    assert!(!err.contains("panicked"), "{ctx}: {err}");
    assert_eq!(out.code, c.code, "{ctx}: {err}");
    if c.code == 2 {
        assert_eq!(out.stdout, "", "{ctx}: bad input printed on stdout");
    }
    assert_eq!(err.lines().count(), 1, "{ctx}: not one line: {err}");
    assert!(
        err.len() <= MAX_LINE,
        "{ctx}: {} bytes on stderr",
        err.len()
    );
    assert!(err.starts_with("gonio: "), "{ctx}: {err}");
    assert!(
        err.to_lowercase().contains(&says.to_lowercase()),
        "{ctx}: message lacks '{says}': {err}"
    );
    if let Some(p) = c.no_output {
        let now = std::fs::read(d.join(p)).ok();
        match &before {
            // An existing file is left exactly as it was.
            Some(b) => assert_eq!(now.as_ref(), Some(b), "{ctx}: {p} was changed"),
            None => {
                if let Some(now) = now {
                    let text = String::from_utf8_lossy(&now);
                    assert!(
                        !text.contains("# status: complete"),
                        "{ctx}: {p} looks complete"
                    );
                    panic!("{ctx}: {p} was left behind:\n{text}");
                }
            }
        }
    }
}

#[test]
fn every_subcommand_rejects_bad_input_cleanly() {
    let d = fixtures();
    // A capture writing locked.csv (the lock is what a second capture meets).
    let _writer = gonio::sweep_file::SweepWriter::resume(&d.join("locked.csv")).unwrap();
    let mut failures = Vec::new();
    for c in CASES {
        if let Err(e) = std::panic::catch_unwind(|| run(&d, c)) {
            let msg = e
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            failures.push(msg);
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        CASES.len(),
        failures.join("\n")
    );
}

/// A file `fit` must read as meant: the readings it fits and what it must say on stderr
/// (`""`: nothing).
struct Accepted {
    file: &'static str,
    n: u64,
    warns: &'static str,
}

const ACCEPTED: &[Accepted] = &[
    Accepted {
        file: "fe-0.115.csv",
        n: 153,
        warns: "",
    },
    Accepted {
        file: "ok-bom.csv",
        n: 153,
        warns: "",
    },
    Accepted {
        file: "ok-cr.csv",
        n: 153,
        warns: "",
    },
    Accepted {
        file: "ok-crlf.csv",
        n: 153,
        warns: "",
    },
    Accepted {
        file: "ok-quoted.csv",
        n: 3,
        warns: "",
    },
    Accepted {
        file: "ok-nonl.csv",
        n: 3,
        warns: "",
    },
    Accepted {
        file: "ok-cut.csv",
        n: 152,
        warns: "1 row(s) left out: the capture was cut while writing the last line",
    },
    Accepted {
        file: "ok-failed.csv",
        n: 100,
        warns: "the capture failed: 53 of 153 plan points have no reading",
    },
    Accepted {
        file: "ok-complete-missing.csv",
        n: 150,
        warns: "the status says complete but 3 of 153 plan points have no reading",
    },
    Accepted {
        file: "ok-repeat.csv",
        n: 3,
        warns: "line 4, theta_i 20 theta_r 20: 50 after 5 on line 2",
    },
    Accepted {
        file: "ok-big.csv",
        n: 3,
        warns: "",
    },
    Accepted {
        file: "ok-semicolon.csv",
        n: 3,
        warns: "",
    },
    Accepted {
        file: "ok-tab.csv",
        n: 3,
        warns: "",
    },
];

#[test]
fn files_are_read_as_meant_and_what_is_left_out_is_said() {
    let d = fixtures();
    let mut failures = Vec::new();
    for a in ACCEPTED {
        let path = d.join(a.file);
        let out =
            crate::util::gonio(&["fit", path.to_str().unwrap(), "--models", "ideal", "--json"]);
        let ctx = format!("fit {}", a.file);
        if out.code != 0 {
            failures.push(format!("{ctx}: exit {}: {}", out.code, out.stderr));
            continue;
        }
        let json: serde_json::Value = serde_json::from_str(&out.stdout).unwrap();
        let n = json["models"][0]["n"].as_u64();
        if n != Some(a.n) {
            failures.push(format!("{ctx}: fitted {n:?} readings, not {}", a.n));
        }
        let ok = if a.warns.is_empty() {
            out.stderr.is_empty()
        } else {
            out.stderr
                .lines()
                .any(|l| l.starts_with("gonio: warning: ") && l.contains(a.warns))
        };
        if !ok {
            failures.push(format!(
                "{ctx}: stderr {:?} lacks {:?}",
                out.stderr, a.warns
            ));
        }
    }
    // A pre-planted symlink at the old temporary name is neither followed nor moved.
    let target = d.join("out.json");
    let out = crate::util::gonio(&[
        "fit",
        d.join("fe-0.115.csv").to_str().unwrap(),
        "--export",
        &format!("json={}", target.display()),
    ]);
    assert!(out.ok(), "{}", out.stderr);
    assert_eq!(std::fs::read(d.join("exists.csv")).unwrap(), b"precious\n");
    assert!(
        std::fs::symlink_metadata(d.join("out.json.tmp"))
            .unwrap()
            .is_symlink()
    );
    assert!(std::fs::symlink_metadata(&target).unwrap().is_file());
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// docs/RELIABILITY.md states both tables' sizes: kept true by this test.
#[test]
fn the_reliability_page_counts_these_cases() {
    let doc =
        std::fs::read_to_string(crate::util::repo_root().join("docs/RELIABILITY.md")).unwrap();
    for said in [
        format!("bad input to every subcommand ({} cases", CASES.len()),
        format!("{} cases in one table", CASES.len()),
        format!("{} files read as meant", ACCEPTED.len()),
    ] {
        assert!(
            doc.contains(&said),
            "docs/RELIABILITY.md should say '{said}'"
        );
    }
}

/// The words of the command a message names, from `start` (e.g. `gonio import table`)
/// to the first `end` after it, without the leading `gonio`; a word in single quotes
/// is one word.
fn hinted(msg: &str, start: &str, end: char) -> Vec<String> {
    let from = msg
        .find(start)
        .unwrap_or_else(|| panic!("no '{start}' in: {msg}"));
    let rest = &msg[from + "gonio ".len()..];
    let cmd = &rest[..rest.find(end).unwrap_or(rest.len())];
    let mut words = Vec::new();
    let mut word = String::new();
    let mut quoted = false;
    for c in cmd.chars() {
        match c {
            '\'' => quoted = !quoted,
            c if c.is_whitespace() && !quoted => {
                if !word.is_empty() {
                    words.push(std::mem::take(&mut word));
                }
            }
            c => word.push(c),
        }
    }
    if !word.is_empty() {
        words.push(word);
    }
    words
}

/// Runs `gonio words...` in `dir`.
fn run_in(dir: &Path, words: &[String]) -> Run {
    gonio_command()
        .args(words)
        .current_dir(dir)
        .output()
        .unwrap()
        .into()
}

/// Every hint that names a command names one that works: the command is run as the
/// message gives it, and succeeds.
#[test]
fn hinted_commands_run() {
    let d = scratch("hints");
    let sweep = simulated(&d, "fe-0.115");
    // A sweep written with ';' and decimal commas: fit refuses it and names the import
    // that converts it; that import works, and its output fits.
    let text = std::fs::read_to_string(&sweep).unwrap();
    let comma: String = text
        .lines()
        .map(|l| {
            if l.starts_with('#') {
                format!("{l}\n")
            } else {
                format!("{}\n", l.replace(',', ";").replace('.', ","))
            }
        })
        .collect();
    std::fs::write(d.join("comma.csv"), comma).unwrap();
    let refused = run_in(&d, &["fit".into(), "comma.csv".into()]);
    assert_eq!(refused.code, 2, "{}", refused.stderr);
    let import = hinted(&refused.stderr, "gonio import table", ')');
    assert!(
        import.contains(&"--decimal-comma".to_string()),
        "{import:?}"
    );
    let converted = run_in(&d, &import);
    assert!(converted.ok(), "{import:?}: {}", converted.stderr);
    let out = &import[import.iter().position(|w| w == "--out").unwrap() + 1];
    let fitted = run_in(&d, &["fit".into(), out.clone(), "--json".into()]);
    assert!(fitted.ok(), "fit {out}: {}", fitted.stderr);

    // A mistyped subcommand and flag: clap's suggestion is kept, and works.
    let typo = run_in(&d, &["fitt".into(), "fe-0.115.csv".into()]);
    assert_eq!(typo.code, 2);
    assert!(
        typo.stderr.contains("did you mean 'fit'?"),
        "{}",
        typo.stderr
    );
    let typo = run_in(
        &d,
        &[
            "fit".into(),
            sweep.display().to_string(),
            "--polt".into(),
            "plots".into(),
        ],
    );
    assert_eq!(typo.code, 2);
    assert!(
        typo.stderr.contains("did you mean '--plot'?"),
        "{}",
        typo.stderr
    );
    let plotted = run_in(
        &d,
        &[
            "fit".into(),
            sweep.display().to_string(),
            "--plot".into(),
            "plots".into(),
        ],
    );
    assert!(plotted.ok(), "{}", plotted.stderr);

    // A port that does not exist: the message names `gonio ports`, which runs.
    let missing = run_in(
        &d,
        &[
            "capture".into(),
            "--port".into(),
            d.join("ttyACM9").display().to_string(),
            "--out".into(),
            "x.csv".into(),
            "--reconnect".into(),
            "0".into(),
        ],
    );
    assert_eq!(missing.code, 1, "{}", missing.stderr);
    let ports = hinted(&missing.stderr, "gonio ports", ' ');
    assert_eq!(ports, ["ports"], "{}", missing.stderr);
    assert!(run_in(&d, &ports).ok());
}
