//! Prints the albedo and reciprocity figures quoted in docs/units.md:
//! `cargo run --release -p brdf-core --example albedo_figures`.

use brdf_core::albedo::{Grid, Rule, albedo, model_brdf, preset_brdf, reciprocity};
use brdf_core::{Model, PRESETS};

/// A BRDF closure behind a reference, so different closures share one table.
type Brdf<'a> = &'a dyn Fn(&[f64; 3], &[f64; 3]) -> Result<f64, brdf_core::ModelError>;

fn main() {
    println!("Directional albedo of the paper's presets (relative units x sr), default rule:");
    println!("| preset | theta_i | rho | error estimate | rho f32 / rho f64 - 1 |");
    println!("|---|---|---|---|---|");
    for p in &PRESETS {
        for ti in [0.0, 20.0, 40.0, 60.0, 80.0, 89.0] {
            let a = albedo(ti, 0.0, &Rule::DEFAULT, preset_brdf::<f64>(p)).unwrap();
            let b = albedo(ti as f32, 0.0, &Rule::DEFAULT, preset_brdf::<f32>(p)).unwrap();
            println!(
                "| {} | {ti} | {:.6} | {:.1e} | {:.1e} |",
                p.name,
                a.rho,
                a.error,
                b.rho / a.rho - 1.0
            );
        }
    }
    println!();
    println!(
        "Convergence: relative error and estimate vs nodes per panel (default panels), reference 64 nodes:"
    );
    let sharp = Model::torrance_sparrow(1.0, 0.005, 0.0).unwrap();
    let fe = brdf_core::Preset::by_name("fe-0.115").unwrap();
    let al = brdf_core::Preset::by_name("al-0.782").unwrap();
    let cases: [(&str, Brdf, f64); 4] = [
        ("f_s sigma=0.005, 70 deg", &model_brdf(&sharp), 70.0),
        ("fe-0.115, 30 deg", &preset_brdf::<f64>(fe), 30.0),
        ("al-0.782, 60 deg", &preset_brdf::<f64>(al), 60.0),
        ("al-0.782, 89 deg", &preset_brdf::<f64>(al), 89.0),
    ];
    for (name, f, ti) in cases {
        let reference = albedo(
            ti,
            0.0,
            &Rule {
                nodes: 64,
                panels: 10,
            },
            f,
        )
        .unwrap()
        .rho;
        print!("| {name} | ref {reference:.12} |");
        for n in [4, 8, 16, 32] {
            let a = albedo(
                ti,
                0.0,
                &Rule {
                    nodes: n,
                    panels: 10,
                },
                f,
            )
            .unwrap();
            print!(
                " n={n}: err {:.1e} est {:.1e} |",
                ((a.rho - reference) / reference).abs(),
                a.error / reference
            );
        }
        println!();
    }
    println!();
    println!("Reciprocity, default grid (9 polar x 24 azimuths):");
    let ts = Model::torrance_sparrow(300.0, 0.1, 25.0).unwrap();
    let r = reciprocity(&Grid::DEFAULT, model_brdf(&ts)).unwrap();
    println!(
        "| Torrance-Sparrow | {:.15} | {:?} -> {:?} |",
        r.max_ratio, r.worst_in, r.worst_out
    );
    for p in &PRESETS {
        let r = reciprocity(&Grid::DEFAULT, preset_brdf::<f64>(p)).unwrap();
        println!(
            "| {} | {:.3} | in ({:.1}, {:.0}) -> out ({:.1}, {:.0}) |",
            p.name, r.max_ratio, r.worst_in.0, r.worst_in.1, r.worst_out.0, r.worst_out.1
        );
    }
}
