//! The bench's results as files and figures: Pareto fronts, `results.csv`, `report.md`,
//! and the number formatting they share.

use std::fmt::Write as _;
use std::path::Path;

use super::{BenchOptions, BenchReport, BenchRow};
use crate::image_io;
use crate::{Error, Result};

/// Median of non-empty values (mean of the middle two for an even count); NaN when empty.
pub fn median(values: &[f64]) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Pareto optimality for minimising both coordinates: `true` for each point that no other
/// point dominates (at most as large in both and smaller in one). Points with a non-finite
/// coordinate are never optimal and dominate nothing; equal points are all optimal.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<bool> {
    let finite = |p: &(f64, f64)| p.0.is_finite() && p.1.is_finite();
    points
        .iter()
        .map(|p| {
            finite(p)
                && !points
                    .iter()
                    .any(|q| finite(q) && q.0 <= p.0 && q.1 <= p.1 && (q.0 < p.0 || q.1 < p.1))
        })
        .collect()
}

/// Marks the Pareto fronts (time vs RMSE, time vs FLIP) within one scene's rows.
pub fn mark_pareto(rows: &mut [BenchRow]) {
    let rmse = pareto_front(&rows.iter().map(|r| (r.time_s, r.rmse)).collect::<Vec<_>>());
    let flip = pareto_front(
        &rows
            .iter()
            .map(|r| (r.time_s, r.flip_mean))
            .collect::<Vec<_>>(),
    );
    for ((r, a), b) in rows.iter_mut().zip(rmse).zip(flip) {
        r.pareto_rmse = a;
        r.pareto_flip = b;
    }
}

pub(super) fn write_text(path: &Path, text: &str) -> Result<()> {
    image_io::write_atomic(path, |tmp| {
        std::fs::write(tmp, text.as_bytes()).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })
    })
}

/// A CSV field, quoted when it holds a comma, a quote or a line break.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// A figure with `decimals` decimals; empty when not finite.
fn num(v: f64, decimals: usize) -> String {
    if v.is_finite() {
        format!("{v:.decimals$}")
    } else {
        String::new()
    }
}

/// An error figure in scientific notation (7 significant digits); empty when not finite.
fn err_num(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.6e}")
    } else {
        String::new()
    }
}

/// Header of `results.csv`.
pub const CSV_HEADER: &str = "scene,config,args,backend,width,height,runs,warmup_reused,time_s,\
times_s,render_ms,gpu_ms,passes,rays_primary,rays_shadow,rays_reflected,rays_refracted,\
rays_total,mrays_per_s,rmse,flip_mean,pareto_rmse,pareto_flip,error";

/// The rows as CSV ([`CSV_HEADER`] first; empty fields where a figure does not apply).
pub fn results_csv(rows: &[BenchRow]) -> String {
    let mut out = String::from(CSV_HEADER);
    out.push('\n');
    for r in rows {
        let ok = r.error.is_none();
        let times = r
            .times_s
            .iter()
            .map(|t| format!("{t:.6}"))
            .collect::<Vec<_>>()
            .join(" ");
        let rays = |v: u64| if ok { v.to_string() } else { String::new() };
        let fields = [
            csv_field(&r.scene),
            csv_field(&r.config),
            csv_field(&r.args),
            csv_field(&r.backend),
            r.width.to_string(),
            r.height.to_string(),
            r.runs.to_string(),
            r.warmup_reused.to_string(),
            num(r.time_s, 6),
            times,
            num(r.render_ms, 3),
            r.gpu_ms.map(|m| num(m, 3)).unwrap_or_default(),
            r.passes.map(|p| p.to_string()).unwrap_or_default(),
            rays(r.rays.primary),
            rays(r.rays.shadow),
            rays(r.rays.reflected),
            rays(r.rays.refracted),
            rays(r.rays.total),
            num(r.mrays_per_s, 6),
            err_num(r.rmse),
            err_num(r.flip_mean),
            r.pareto_rmse.to_string(),
            r.pareto_flip.to_string(),
            csv_field(r.error.as_deref().unwrap_or("")),
        ];
        out += &fields.join(",");
        out.push('\n');
    }
    out
}

/// Seconds for people: "12.3 s", "456 ms".
pub(super) fn fmt_secs(s: f64) -> String {
    if !s.is_finite() {
        "-".into()
    } else if s >= 100.0 {
        format!("{s:.0} s")
    } else if s >= 1.0 {
        format!("{s:.2} s")
    } else {
        format!("{:.1} ms", s * 1e3)
    }
}

/// An integer with thousands separators.
fn thousands(v: u64) -> String {
    let s = v.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

fn sci(v: f64) -> String {
    if !v.is_finite() {
        "-".into()
    } else if v == 0.0 {
        "0".into()
    } else {
        format!("{v:.2e}")
    }
}

/// `report.md`: how the figures were made, then one table per scene sorted by time, with
/// the Pareto-optimal rows marked, and the plot.
pub fn report_markdown(report: &BenchReport, opts: &BenchOptions) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# fragtrace bench\n");
    let _ = writeln!(
        s,
        "- fragtrace {}; {} px; one warm-up, then {} timed run(s) per configuration, median \
         wall time of the render call (grid build, shader compilation and upload included); \
         runs stop once one takes over {} s.",
        env!("CARGO_PKG_VERSION"),
        opts.size,
        opts.runs,
        opts.max_seconds
    );
    let _ = writeln!(
        s,
        "- GL device: {}; CPU: {} threads.",
        report.gl_device.as_deref().unwrap_or("none used"),
        rayon::current_num_threads()
    );
    if let Some(why) = &report.left_out_why {
        let _ = writeln!(s, "- Left out: {} ({why}).", report.left_out.join(", "));
    }
    let _ = writeln!(
        s,
        "- Error against a CPU f64 render of the same scene and size: RMSE over linear RGB; \
         FLIP = mean FLIP error of the images clamped to [0, 1] as 8-bit sRGB, {:.2} pixels \
         per degree.",
        crate::compare::FLIP_PIXELS_PER_DEGREE
    );
    let _ = writeln!(
        s,
        "- Pareto: **RMSE** / **FLIP** marks a configuration that no other is both at least \
         as fast as and at most as wrong as (in RMSE / in FLIP), and better in one.\n"
    );
    let mut scenes: Vec<&str> = Vec::new();
    for r in &report.rows {
        if !scenes.contains(&r.scene.as_str()) {
            scenes.push(&r.scene);
        }
    }
    for scene in scenes {
        let mut rows: Vec<&BenchRow> = report.rows.iter().filter(|r| r.scene == scene).collect();
        rows.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
        let tris = report.triangles.get(scene).copied().unwrap_or(0);
        let _ = writeln!(s, "## {scene} ({} triangles)\n", thousands(tris as u64));
        let _ = writeln!(
            s,
            "| config | arguments | time | runs | GPU time | passes | rays | Mrays/s | RMSE | FLIP | Pareto |"
        );
        let _ = writeln!(s, "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|");
        let mut failed = Vec::new();
        for r in rows {
            if let Some(e) = &r.error {
                failed.push((r, e));
                continue;
            }
            let pareto = [(r.pareto_rmse, "RMSE"), (r.pareto_flip, "FLIP")]
                .iter()
                .filter(|(on, _)| *on)
                .map(|(_, n)| format!("**{n}**"))
                .collect::<Vec<_>>()
                .join(" ");
            let runs = if r.warmup_reused {
                "1 (warm-up)".to_string()
            } else {
                r.runs.to_string()
            };
            let _ = writeln!(
                s,
                "| {} | `{}` | {} | {} | {} | {} | {} | {:.3} | {} | {} | {} |",
                r.config,
                r.args,
                fmt_secs(r.time_s),
                runs,
                r.gpu_ms.map(|m| fmt_secs(m / 1e3)).unwrap_or("-".into()),
                r.passes.map(thousands).unwrap_or("-".into()),
                thousands(r.rays.total),
                r.mrays_per_s,
                sci(r.rmse),
                sci(r.flip_mean),
                pareto
            );
        }
        for (r, e) in failed {
            let _ = writeln!(s, "\n- {} (`{}`) failed: {}", r.config, r.args, e);
        }
        s.push('\n');
    }
    let _ = writeln!(s, "![time against error](speed_vs_error.png)");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_on_known_points() {
        // (time, error)
        let pts = [
            (1.0, 0.5),           // fastest: optimal
            (2.0, 0.1),           // slower, better: optimal
            (3.0, 0.1),           // dominated by (2, 0.1)
            (2.5, 0.3),           // dominated by (2, 0.1)
            (10.0, 0.0),          // slowest, exact: optimal
            (10.0, 0.0),          // its twin: optimal too
            (f64::NAN, 0.0),      // failed: never optimal
            (0.5, f64::INFINITY), // failed: dominates nothing
            (1.0, 0.6),           // dominated by (1, 0.5) on error alone
        ];
        assert_eq!(
            pareto_front(&pts),
            vec![true, true, false, false, true, true, false, false, false]
        );
        assert!(pareto_front(&[]).is_empty());
        assert_eq!(pareto_front(&[(1.0, 1.0)]), vec![true]);
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&[]).is_nan());
    }

    #[test]
    fn csv_quotes_what_needs_it() {
        assert_eq!(csv_field("a b"), "a b");
        assert_eq!(csv_field("a,\"b\""), "\"a,\"\"b\"\"\"");
        assert_eq!(thousands(1_993_148), "1,993,148");
        assert_eq!(thousands(12), "12");
    }
}
