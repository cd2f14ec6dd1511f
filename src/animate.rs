//! `fragtrace render SCENE --frames A..B -o out/frame_####.png`: an animation in one
//! process. The structure is built and the scene uploaded once ([`Renderer`]); every frame
//! is rendered from its camera on the scene's path and handed to encoder threads, which
//! write it (atomically) while the next frame renders. Progress is shown over frames with
//! an ETA, and `--stats` writes per-frame phases.

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use serde::Serialize;

use crate::farm::template::OutputTemplate;
use crate::image_io::{self, Format, Image};
use crate::options::RenderOptions;
use crate::output::Readback;
use crate::progress::Progress;
use crate::render::{self, RenderStats, Renderer};
use crate::scene::Scene;
use crate::{Error, Result};

/// What `--stats` writes for an animation: the set-up, then every frame's phases.
#[derive(Serialize)]
pub struct AnimationStats {
    /// Frames rendered.
    pub frames: u32,
    /// Loading, structure build and renderer set-up before the first frame (ms).
    pub setup_ms: f64,
    /// From the first frame's start to the last file written (ms).
    pub frames_ms: f64,
    /// The frames after the first (its uploads and compiles) per second.
    pub steady_fps: f64,
    /// The GPU kernels that rendered the frames, run by run, in frame order (empty on the
    /// CPU): one run, or with `--kernel auto` on a cold start the looped kernel's first
    /// frames while the compute kernel compiled, then compute's (issue 52).
    pub kernels: Vec<KernelFrames>,
    /// Per frame: its number, file, render statistics and encode-and-write time.
    pub per_frame: Vec<FrameStats>,
}

/// Consecutive frames one GPU kernel rendered (of [`AnimationStats::kernels`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct KernelFrames {
    /// The kernel (`GpuStats::kernel`).
    pub kernel: String,
    /// It rendered them while the compute kernel compiled (`GpuStats::cold_start`).
    pub cold_start: bool,
    /// The row from which the compute kernel, its compile done, rendered the rest of the
    /// last frame (`GpuStats::handover_row`).
    pub handover_row: Option<u32>,
    /// The first frame's number.
    pub first: u32,
    /// The last frame's number.
    pub last: u32,
    /// How many frames.
    pub frames: u32,
}

/// The runs of frames each GPU kernel rendered, in frame order.
pub fn kernel_runs(per_frame: &[FrameStats]) -> Vec<KernelFrames> {
    let mut runs: Vec<KernelFrames> = Vec::new();
    for f in per_frame {
        let Some(g) = f.render.gpu.as_ref() else {
            continue;
        };
        match runs.last_mut() {
            Some(r) if r.kernel == g.kernel && r.cold_start == g.cold_start => {
                r.last = f.frame;
                r.frames += 1;
                r.handover_row = g.handover_row;
            }
            _ => runs.push(KernelFrames {
                kernel: g.kernel.clone(),
                cold_start: g.cold_start,
                handover_row: g.handover_row,
                first: f.frame,
                last: f.frame,
                frames: 1,
            }),
        }
    }
    runs
}

/// The kernels of `runs` for the summary line: `compute kernel`, or with a cold start
/// `looped kernel for frames 0-1 (compute compiling), compute kernel for frames 2-119`;
/// where compute took over part way down a frame, `... (compute compiling; compute from row
/// 512 of frame 1) ...`.
pub fn describe_kernels(runs: &[KernelFrames]) -> String {
    let many = runs.len() > 1 || runs.first().is_some_and(|r| r.frames > 1);
    let why = |r: &KernelFrames| match (r.cold_start, r.handover_row) {
        (false, _) => String::new(),
        (true, None) => " (compute compiling)".to_string(),
        (true, Some(row)) if many => {
            format!(
                " (compute compiling; compute from row {row} of frame {})",
                r.last
            )
        }
        (true, Some(row)) => format!(" (compute compiling; compute from row {row})"),
    };
    match runs {
        [] => String::new(),
        [r] => format!("{} kernel{}", r.kernel, why(r)),
        _ => runs
            .iter()
            .map(|r| {
                let frames = if r.frames == 1 {
                    format!("frame {}", r.first)
                } else {
                    format!("frames {}-{}", r.first, r.last)
                };
                format!("{} kernel for {frames}{}", r.kernel, why(r))
            })
            .collect::<Vec<_>>()
            .join(", "),
    }
}

/// One frame of [`AnimationStats`].
#[derive(Serialize)]
pub struct FrameStats {
    /// Frame number.
    pub frame: u32,
    /// The file written.
    pub file: PathBuf,
    /// The render (phases under `gpu.phases_ms`).
    pub render: RenderStats,
    /// Encoding and writing the file, on an encoder thread (ms).
    pub write_ms: f64,
}

/// One finished frame on its way to an encoder thread.
struct Job {
    index: usize,
    path: PathBuf,
    image: Image,
    srgb8: Option<Vec<u8>>,
}

/// Renders `frames` of `scene`'s camera path with `opts` into files named by `output`
/// (a run of `#` or `{frame}` becomes the frame number), returning the statistics;
/// `progress` shows the frames bar and the backend notice (off with `-q`).
pub fn render_frames(
    scene: &Scene,
    opts: &RenderOptions,
    frames: &[u32],
    output: &Path,
    progress: bool,
) -> Result<AnimationStats> {
    let t_setup = Instant::now();
    let path = scene.animation.as_ref().ok_or_else(|| {
        Error::Usage(format!(
            "--frames needs a camera path: {} has no [animation] table (docs/scene-format.md)",
            scene.source
        ))
    })?;
    let template = OutputTemplate::new(output)?;
    if frames.is_empty() {
        return Err(Error::Internal("an empty frame list".into()));
    }
    if !template.has_frame() && frames.len() > 1 {
        return Err(Error::Usage(format!(
            "-o {} has no frame number in it: name frames with a run of # (frame_####.png) or {{frame}}",
            output.display()
        )));
    }
    let first_file = template.path(Some(frames[0]), None);
    let format = Format::from_path(&first_file)?;
    // The frames' folder is made when missing (a fresh volume of a farm), as the parts'.
    if let Some(dir) = first_file.parent() {
        if !dir.as_os_str().is_empty() && !dir.is_dir() {
            std::fs::create_dir_all(dir).map_err(|e| {
                Error::Usage(format!(
                    "{}: cannot create the frames' folder: {e}",
                    dir.display()
                ))
            })?;
        }
    }
    for f in frames {
        image_io::remove_stale_partials(&template.path(Some(*f), None));
    }
    let mut opts = opts.clone();
    opts.readback = Readback {
        aov: false,
        srgb8: format.is_srgb8(),
    };
    opts.progress = false;
    opts.validate()?;
    // `--accel auto`: the structure of the backend the context settles.
    let (ctx, opts) = render::context_for(&opts, scene, progress)?;
    let prepared = render::prepare(scene, &opts)?;
    let mut renderer: Renderer<'_> = match &ctx {
        Some(ctx) => prepared.gl_renderer(ctx, &opts)?,
        None => prepared.cpu_renderer(&opts),
    };
    let setup_ms = t_setup.elapsed().as_secs_f64() * 1e3;
    let count = frames.len() as u32;
    let bar = Progress::bar(progress, count as u64, "frames");
    let t_frames = Instant::now();
    let mut per_frame: Vec<Option<FrameStats>> = (0..count).map(|_| None).collect();
    let mut first_done: Option<Instant> = None;
    // Encoders: several frames can be encoding while the GPU renders the next; at most
    // two frames wait in the queue, so memory stays bounded.
    let workers = std::thread::available_parallelism()
        .map_or(2, |n| n.get())
        .clamp(1, 4);
    let (tx, rx) = mpsc::sync_channel::<Job>(2);
    let rx = Arc::new(Mutex::new(rx));
    let (done_tx, done_rx) = mpsc::channel::<(usize, Result<f64>)>();
    let result = std::thread::scope(|s| -> Result<()> {
        for _ in 0..workers {
            let rx = Arc::clone(&rx);
            let done = done_tx.clone();
            s.spawn(move || loop {
                let job = match rx.lock().expect("queue").recv() {
                    Ok(j) => j,
                    Err(_) => return,
                };
                let t = Instant::now();
                let r = match job.srgb8 {
                    Some(rgb) => {
                        let r = image_io::write_srgb8(
                            &job.path,
                            job.image.width,
                            job.image.height,
                            &rgb,
                        );
                        // For the next frame's read-back (`pool`): its pages are touched.
                        crate::pool::give_back(rgb);
                        r
                    }
                    None => image_io::write_image(&job.path, &job.image),
                };
                let _ = done.send((job.index, r.map(|()| t.elapsed().as_secs_f64() * 1e3)));
            });
        }
        drop(done_tx);
        let mut render_err = None;
        for (index, &frame) in frames.iter().enumerate() {
            let camera = path.camera_at(frame);
            let out = match renderer.render(&camera) {
                Ok(o) => o,
                Err(e) => {
                    render_err = Some(e);
                    break;
                }
            };
            let finite = match out.nonfinite {
                Some(n) => n == 0,
                None => out.image.all_finite(),
            };
            if !finite {
                render_err = Some(Error::Internal(format!(
                    "frame {frame}: the render produced a NaN or Inf pixel"
                )));
                break;
            }
            let file = template.path(Some(frame), None);
            per_frame[index] = Some(FrameStats {
                frame,
                file: file.clone(),
                render: out.stats,
                write_ms: 0.0,
            });
            let job = Job {
                index,
                path: file,
                image: out.image,
                srgb8: out.srgb8,
            };
            if tx.send(job).is_err() {
                break;
            }
            first_done.get_or_insert_with(Instant::now);
            bar.inc(1);
        }
        drop(tx);
        // Every encoder's answer (they finish the queue, then the channel closes).
        let mut write_err = None;
        for (index, r) in done_rx {
            match r {
                Ok(ms) => {
                    if let Some(f) = per_frame[index].as_mut() {
                        f.write_ms = ms;
                    }
                }
                Err(e) => {
                    write_err.get_or_insert(e);
                }
            }
        }
        match (render_err, write_err) {
            (Some(e), _) | (None, Some(e)) => Err(e),
            (None, None) => Ok(()),
        }
    });
    bar.finish();
    result?;
    let frames_ms = t_frames.elapsed().as_secs_f64() * 1e3;
    let steady_fps = match first_done {
        Some(t) if count > 1 => (count - 1) as f64 / t.elapsed().as_secs_f64().max(1e-9),
        _ => 0.0,
    };
    let per_frame: Vec<FrameStats> = per_frame.into_iter().flatten().collect();
    Ok(AnimationStats {
        frames: count,
        setup_ms,
        frames_ms,
        steady_fps,
        kernels: kernel_runs(&per_frame),
        per_frame,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(kernel: &str, cold_start: bool, first: u32, last: u32) -> KernelFrames {
        KernelFrames {
            kernel: kernel.into(),
            cold_start,
            handover_row: None,
            first,
            last,
            frames: last - first + 1,
        }
    }

    /// The summary line names one kernel as before, and a cold start's runs frame by frame.
    #[test]
    fn kernels_are_described_by_their_frames() {
        assert_eq!(describe_kernels(&[]), "");
        assert_eq!(
            describe_kernels(&[run("compute", false, 0, 119)]),
            "compute kernel"
        );
        assert_eq!(
            describe_kernels(&[run("looped", true, 0, 0), run("compute", false, 1, 119)]),
            "looped kernel for frame 0 (compute compiling), compute kernel for frames 1-119"
        );
        assert_eq!(
            describe_kernels(&[run("looped", true, 3, 5)]),
            "looped kernel (compute compiling)"
        );
        // The compute kernel took over part way down the last looped frame.
        let handed = KernelFrames {
            handover_row: Some(512),
            ..run("looped", true, 0, 1)
        };
        assert_eq!(
            describe_kernels(&[handed.clone(), run("compute", false, 2, 119)]),
            "looped kernel for frames 0-1 (compute compiling; compute from row 512 of frame 1), \
             compute kernel for frames 2-119"
        );
        let one = KernelFrames {
            handover_row: Some(16),
            ..run("looped", true, 0, 0)
        };
        assert_eq!(
            describe_kernels(&[one]),
            "looped kernel (compute compiling; compute from row 16)"
        );
    }
}
