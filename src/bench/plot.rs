//! `speed_vs_error.png`: time against error per scene, drawn with plotters and the bundled
//! font (no system fonts needed).

use std::path::Path;

use super::BenchRow;
use crate::image_io;
use crate::{Error, Result};

static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

fn register_font() -> Result<()> {
    static ONCE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *ONCE.get_or_init(|| {
        plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, FONT)
            .is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(Error::Internal(
            "the bundled font could not be loaded".into(),
        ))
    }
}

const PALETTE: &[(u8, u8, u8)] = &[
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
];

/// Draws `speed_vs_error.png`: one row of panels per scene, time (log axis) against RMSE on
/// the left and FLIP on the right; one labelled point per configuration (same colour for a
/// configuration in every panel) and each panel's Pareto front as a line.
pub fn plot_speed_vs_error(path: &Path, rows: &[BenchRow]) -> Result<()> {
    use plotters::prelude::*;
    register_font()?;
    let mut scenes: Vec<&str> = Vec::new();
    let mut configs: Vec<&str> = Vec::new();
    for r in rows {
        if !scenes.contains(&r.scene.as_str()) {
            scenes.push(&r.scene);
        }
        if !configs.contains(&r.config.as_str()) {
            configs.push(&r.config);
        }
    }
    let (pw, ph) = (720u32, 460u32);
    let (w, h) = (2 * pw, ph * scenes.len().max(1) as u32);
    let mut buf = vec![0u8; (w * h * 3) as usize];
    let draw_err = |e: &dyn std::fmt::Display| Error::Internal(format!("plot: {e}"));
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| draw_err(&e))?;
        let panels = root.split_evenly((scenes.len().max(1), 2));
        for (si, scene) in scenes.iter().enumerate() {
            let ok: Vec<&BenchRow> = rows
                .iter()
                .filter(|r| r.scene == *scene && r.error.is_none() && r.time_s > 0.0)
                .collect();
            for (pi, metric) in ["RMSE", "FLIP"].iter().enumerate() {
                let area = &panels[si * 2 + pi];
                let value = |r: &BenchRow| if pi == 0 { r.rmse } else { r.flip_mean };
                let on_front = |r: &BenchRow| {
                    if pi == 0 {
                        r.pareto_rmse
                    } else {
                        r.pareto_flip
                    }
                };
                let (mut t0, mut t1) = ok.iter().fold((f64::INFINITY, 0.0f64), |(a, b), r| {
                    (a.min(r.time_s), b.max(r.time_s))
                });
                if !t0.is_finite() {
                    (t0, t1) = (0.1, 1.0);
                }
                let (t0, t1) = (t0 / 1.6, t1 * 1.6);
                // Errors on a log axis too (they span decades); an error of exactly 0
                // sits on the bottom line, labelled 0.
                let positive = ok
                    .iter()
                    .map(|r| value(r))
                    .filter(|v| *v > 0.0 && v.is_finite());
                let (lo, hi) =
                    positive.fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
                let (floor, top) = if hi > 0.0 {
                    (lo / 4.0, hi * 2.0)
                } else {
                    (1e-6, 1e-3)
                };
                let y_of = move |v: f64| if v > 0.0 { v.max(floor) } else { floor };
                let mut y_ticks = vec![floor];
                y_ticks.extend(
                    log_ticks(floor, top)
                        .into_iter()
                        .filter(|v| *v > floor * 1.5),
                );
                let mut chart = ChartBuilder::on(area)
                    .caption(
                        format!("{scene}: {metric} against time"),
                        ("sans-serif", 20).into_font(),
                    )
                    .margin(12)
                    .x_label_area_size(40)
                    .y_label_area_size(70)
                    .build_cartesian_2d(
                        (t0..t1).log_scale().with_key_points(log_ticks(t0, t1)),
                        (floor..top).log_scale().with_key_points(y_ticks),
                    )
                    .map_err(|e| draw_err(&e))?;
                chart
                    .configure_mesh()
                    .x_desc("median wall time (s, log scale)")
                    .y_desc(format!("{metric} vs CPU f64 (log scale)"))
                    .x_label_formatter(&|v| fmt_tick(*v))
                    .y_label_formatter(&|v| {
                        if *v <= floor * 1.000_001 {
                            "0".into()
                        } else {
                            format!("{v:.0e}")
                        }
                    })
                    .label_style(("sans-serif", 13).into_font())
                    .axis_desc_style(("sans-serif", 14).into_font())
                    .draw()
                    .map_err(|e| draw_err(&e))?;
                let mut front: Vec<(f64, f64)> = ok
                    .iter()
                    .filter(|r| on_front(r))
                    .map(|r| (r.time_s, y_of(value(r))))
                    .collect();
                front.sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.total_cmp(&a.1)));
                chart
                    .draw_series(LineSeries::new(
                        front,
                        ShapeStyle::from(&BLACK.mix(0.6)).stroke_width(2),
                    ))
                    .map_err(|e| draw_err(&e))?;
                // Labels: placed in pixel space, pushed down when they would overlap.
                let mut placed: Vec<(i32, i32, i32)> = Vec::new();
                for r in &ok {
                    let ci = configs.iter().position(|c| *c == r.config).unwrap_or(0);
                    let (cr, cg, cb) = PALETTE[ci % PALETTE.len()];
                    let colour = RGBColor(cr, cg, cb);
                    let p = (r.time_s, y_of(value(r)));
                    chart
                        .draw_series(std::iter::once(Circle::new(p, 5, colour.filled())))
                        .map_err(|e| draw_err(&e))?;
                    let (px, mut py) = chart.backend_coord(&p);
                    let lw = 7 * r.config.len() as i32;
                    let (mut lx, lh) = (px + 8, 15);
                    if lx + lw > area.get_base_pixel().0 + pw as i32 - 4 {
                        lx = px - 8 - lw;
                    }
                    py -= 7;
                    while placed
                        .iter()
                        .any(|&(x, y, pw_)| lx < x + pw_ && x < lx + lw && (py - y).abs() < lh)
                    {
                        py += lh;
                    }
                    placed.push((lx, py, lw));
                    root.draw(&Text::new(
                        r.config.clone(),
                        (lx, py),
                        ("sans-serif", 13).into_font().color(&colour),
                    ))
                    .map_err(|e| draw_err(&e))?;
                }
            }
        }
        root.present().map_err(|e| draw_err(&e))?;
    }
    image_io::write_atomic(path, |tmp| {
        image::save_buffer_with_format(
            tmp,
            &buf,
            w,
            h,
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| Error::Image {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    })
}

/// Tick values of a log axis over `[lo, hi]`: 1-2-5 in each decade (1-1.5-2-3-5-7 when
/// that gives fewer than four).
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let ticks = |mantissas: &[f64]| {
        let (d0, d1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
        let mut v = Vec::new();
        for d in d0..=d1 {
            for m in mantissas {
                let t = m * 10f64.powi(d);
                if t >= lo && t <= hi {
                    v.push(t);
                }
            }
        }
        v
    };
    let coarse = ticks(&[1.0, 2.0, 5.0]);
    if coarse.len() >= 4 {
        coarse
    } else {
        ticks(&[1.0, 1.5, 2.0, 3.0, 5.0, 7.0])
    }
}

/// A tick label without float noise: 0.05, 1.5, 200.
fn fmt_tick(v: f64) -> String {
    if v >= 10.0 {
        format!("{v:.0}")
    } else {
        let decimals = (2.0 - v.log10().floor()).max(1.0) as usize;
        let s = format!("{v:.decimals$}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_axis_ticks_and_labels() {
        assert_eq!(
            log_ticks(0.01, 1.0),
            vec![0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0]
        );
        assert_eq!(log_ticks(1.0, 2.5), vec![1.0, 1.5, 2.0]);
        let labels: Vec<String> = [0.05, 0.15, 1.5, 2.0, 300.0]
            .iter()
            .map(|v| fmt_tick(*v))
            .collect();
        assert_eq!(labels, ["0.05", "0.15", "1.5", "2", "300"]);
    }
}
