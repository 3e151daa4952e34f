//! The speed-against-error chart of `gonio bench --plot`.

use std::path::Path;

use plotters::prelude::*;

use super::variants::VariantResult;
use crate::plot::{CrispText, FONT, PlotError, ensure_font, one_line};

/// The speed-against-error chart of `gonio bench --plot`: every evaluation variant as a
/// point, nanoseconds per evaluation (log) against its largest relative error (log).
/// Written through [`crate::outfile`] (an existing `png` needs `force`).
pub fn speed_vs_error(png: &Path, rows: &[VariantResult], force: bool) -> Result<(), PlotError> {
    ensure_font()?;
    let target = crate::outfile::Target::new(png, force);
    crate::outfile::check(target).map_err(|e| PlotError(e.to_string()))?;
    let mut drawn = Ok(());
    crate::outfile::write_with(target, ".png", |tmp| {
        drawn = draw_chart(tmp.path(), png, rows);
        drawn.clone().map_err(|e| std::io::Error::other(e.0))
    })
    .map_err(|e| match drawn {
        Err(d) => d,
        Ok(()) => PlotError(one_line(&e.to_string())),
    })?;
    Ok(())
}

/// Draws the chart into `file` (messages name `png`, the target).
fn draw_chart(file: &Path, png: &Path, rows: &[VariantResult]) -> Result<(), PlotError> {
    let fail = |e: String| {
        PlotError(one_line(&format!(
            "cannot write the plot {}: {e}",
            png.display()
        )))
    };
    let root = CrispText::new(BitMapBackend::new(file, (1100, 640)))
        .map_err(fail)?
        .into_drawing_area();
    let draw = || -> Result<(), String> {
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let floor = 1e-16; // the f64 reference itself has error 0: drawn at the floor
        let errs: Vec<f64> = rows.iter().map(|r| r.max_rel_error.max(floor)).collect();
        let (x0, x1) = rows.iter().fold((f64::INFINITY, 0.0f64), |(a, b), r| {
            (a.min(r.ns_per_eval), b.max(r.ns_per_eval))
        });
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "Speed against error of the evaluation variants (one core)",
                (FONT, 24),
            )
            .margin(20)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(
                (x0 * 0.6..x1 * 1.6).log_scale(),
                (floor * 0.5..1e-1).log_scale(),
            )
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc("nanoseconds per evaluation (log)")
            .y_desc("largest relative error vs f64 (log)")
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 17))
            .draw()
            .map_err(|e| e.to_string())?;
        for (k, (r, &e)) in rows.iter().zip(&errs).enumerate() {
            let color = Palette99::pick(k).to_rgba();
            chart
                .draw_series([Circle::new((r.ns_per_eval, e), 7, color.filled())])
                .map_err(|e| e.to_string())?
                .label(format!(
                    "{} ({:.1} ns, {:.1e})",
                    r.variant, r.ns_per_eval, r.max_rel_error
                ))
                .legend(move |(x, y)| Circle::new((x, y), 6, color.filled()));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK.mix(0.3))
            .label_font((FONT, 14))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())
    };
    draw().map_err(fail)
}
