//! `--meta KEY=VALUE`, `--role` and `--of` of `gonio simulate` (capture shares them):
//! the lines a sweep's header gets, carried through a fit's ASTM export, kept on
//! `--resume`, and the role lines read back.

use gonio::sweep_file::{Role, read_sweep};

use crate::util::{gonio, one_line, scratch};

/// Issue 51: `simulate --meta ...` writes the measurement's lines (keys in any case);
/// `fit --export astm` carries them; `--resume` keeps them once, refuses a different
/// value, and accepts the same one or none.
#[test]
fn meta_lines_are_written_exported_and_kept_on_resume() {
    let d = scratch("meta");
    let f = d.join("fe.csv");
    let sim = |extra: &[&str]| {
        let mut args = vec![
            "simulate",
            "--material",
            "fe-0.115",
            "--out",
            f.to_str().unwrap(),
            "-q",
        ];
        args.extend_from_slice(extra);
        gonio(&args)
    };
    let meta = [
        "--meta",
        "wavelength=532",
        "--meta",
        "Sample=coupon 7",
        "--meta",
        "POLARISATION=s",
        "--meta",
        "signature=sig.csv",
        "--meta",
        "temperature=21.5 C",
    ];
    let out = sim(&meta);
    assert!(out.ok(), "{}", out.stderr);
    let text = std::fs::read_to_string(&f).unwrap();
    for line in [
        "# wavelength: 532 nm\n",
        "# polarization: s\n",
        "# signature: sig.csv\n",
        "# temperature: 21.5 C\n",
        // The simulated sample keeps saying what it is.
        "# sample: coupon 7 (simulated fe-0.115 noise=0.005)\n",
    ] {
        assert_eq!(text.matches(line).count(), 1, "{line}{text}");
    }
    let m = read_sweep(&f).unwrap().measurement().unwrap();
    assert_eq!(m.wavelength_nm, Some(532.0));
    assert_eq!(m.role, None);
    // Through the fit's ASTM export.
    let astm = d.join("fe.astm");
    let fit = gonio(&[
        "fit",
        f.to_str().unwrap(),
        "--models",
        "ideal",
        "--scale",
        "0.0005",
        "--export",
        &format!("astm={}", astm.display()),
    ]);
    assert!(fit.ok(), "{}", fit.stderr);
    let table = std::fs::read_to_string(&astm).unwrap();
    for line in [
        "WAVELENGTH 532 nm",
        "POLARIZATION s",
        "SIGNATURE sig.csv",
        "SAMPLE coupon 7 (simulated fe-0.115 noise=0.005)",
        "TEMPERATURE 21.5 C",
    ] {
        assert!(table.contains(&format!("\n{line}\n")), "{line}");
    }
    // --resume: the same values, or none, continue the file (complete: nothing to
    // do) with its header as it was; a different or a new one is refused.
    for extra in [&meta[..], &[]] {
        let out = sim(&[&["--resume"], extra].concat());
        assert!(out.ok(), "{}", out.stderr);
        assert_eq!(std::fs::read_to_string(&f).unwrap(), text);
    }
    for (extra, says) in [
        (
            &["--meta", "wavelength=633"][..],
            "records wavelength '532 nm', not '633 nm'",
        ),
        (&["--meta", "operator=J. Doe"][..], "records no operator"),
        (
            &["--meta", "sample=coupon 8"][..],
            "holds readings of 'coupon 7 (simulated",
        ),
    ] {
        let out = sim(&[&["--resume"], extra].concat());
        assert_eq!(out.code, 2, "{extra:?}: {}", out.stderr);
        assert!(one_line(&out.stderr).contains(says), "{}", out.stderr);
        assert_eq!(std::fs::read_to_string(&f).unwrap(), text);
    }
}

/// Issue 51: a dark and a signature capture say which sweep they belong to; the lines
/// read back through the sweep reader, and the sample's sweep names its signature.
#[test]
fn role_lines_read_back() {
    let d = scratch("role");
    let (main, sig, dark) = (d.join("fe.csv"), d.join("sig.csv"), d.join("dark.csv"));
    for (file, extra) in [
        (&sig, &["--role", "signature", "--of", "fe.csv"][..]),
        (&dark, &["--role", "DARK", "--of", "fe.csv"][..]),
        (&main, &["--meta", "signature=sig.csv"][..]),
    ] {
        let mut args = vec![
            "simulate",
            "--material",
            "fe-0.115",
            "--out",
            file.to_str().unwrap(),
            "-q",
        ];
        args.extend_from_slice(extra);
        let out = gonio(&args);
        assert!(out.ok(), "{extra:?}: {}", out.stderr);
    }
    let read = |p: &std::path::Path| {
        let s = read_sweep(p).unwrap();
        assert!(s.unknown_keys.is_empty(), "{:?}", s.unknown_keys);
        s.measurement().unwrap()
    };
    let (s, k, m) = (read(&sig), read(&dark), read(&main));
    assert_eq!(
        (s.role, s.of.as_deref()),
        (Some(Role::Signature), Some("fe.csv"))
    );
    assert_eq!(
        (k.role, k.of.as_deref()),
        (Some(Role::Dark), Some("fe.csv"))
    );
    assert_eq!((m.role, m.signature.as_deref()), (None, Some("sig.csv")));
    let text = std::fs::read_to_string(&dark).unwrap();
    assert!(text.contains("\n# role: dark\n# of: fe.csv\n"), "{text}");
}
