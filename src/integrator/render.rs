//! The render loop: passes of one sample per pixel, rows in parallel (rayon), accumulated in a
//! fixed order so the image is the same for a given seed whatever the thread count.

use super::{
    Integrator, IntegratorKind, IntegratorOptions, SampleSink, Sampler, SpectralSink, Splats, Stats,
};
use crate::film::Film;
use crate::film::spectral::{SpectralBins, SpectralFilm};
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;
use std::sync::{Mutex, MutexGuard};
use std::time::Instant;

#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// Index of the first sample: samples `first_sample..first_sample + spp` are rendered, each
    /// drawn from (seed, pixel, sample index), so ranges of one render can run apart and merge.
    pub first_sample: u32,
    /// Number of samples per pixel.
    pub spp: u32,
    pub seed: u64,
    /// Worker threads (all cores when `None`).
    pub threads: Option<usize>,
    /// Stop after the pass during which this many seconds have elapsed.
    pub time_limit: Option<f64>,
    /// Show a progress bar (on a terminal only).
    pub progress: bool,
    /// Also make a spectral image of this many bins over the camera's range (`--spectral`).
    pub spectral: Option<usize>,
    /// Set from another thread to stop the render: rows not yet started in the current pass
    /// are skipped and [`render`] returns [`CANCELLED`] (the Python API's Ctrl-C).
    pub cancel: Option<Cancel>,
}

/// A flag that stops a render when set ([`RenderSettings::cancel`]).
pub type Cancel = std::sync::Arc<std::sync::atomic::AtomicBool>;

/// The error of a render stopped through [`RenderSettings::cancel`].
pub const CANCELLED: &str = "the render was cancelled";

fn cancelled(c: Option<&Cancel>) -> bool {
    c.is_some_and(|c| c.load(std::sync::atomic::Ordering::Relaxed))
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            first_sample: 0,
            spp: 16,
            seed: 0,
            threads: None,
            time_limit: None,
            progress: false,
            spectral: None,
            cancel: None,
        }
    }
}

pub struct RenderOutput {
    pub film: Film,
    pub stats: Stats,
    /// Wall-clock seconds of rendering (scene loading excluded).
    pub seconds: f64,
}

impl RenderOutput {
    /// The render's statistics as JSON: the CLI's `--stats` document and the Python API's
    /// `Render.stats`.
    pub fn stats_json(&self, kind: IntegratorKind, opts: &IntegratorOptions) -> serde_json::Value {
        let (out, s) = (self, &self.stats);
        let mut json = serde_json::json!({
            "integrator": kind.name(),
            "options": opts,
            // the instruction set of the ray kernels (the scene's BVH is built with the process's)
            "isa": crate::geometry::Isa::active().name(),
            "spp": out.film.spp,
            "width": out.film.width,
            "height": out.film.height,
            "seconds": out.seconds,
            "samples_per_second": s.paths as f64 / out.seconds.max(1e-9),
            "rays": s.rays,
            "rays_per_second": s.rays as f64 / out.seconds.max(1e-9),
            "nan_inf_rejected": s.nan_inf_rejected,
            "dropped_strategy_pdfs": s.dropped_strategy_pdfs,
            "paths": s.paths,
            "contributing_paths": s.contributing_paths,
            "contributing_paths_by_segments": s.contributing_by_length,
        });
        if !s.reset_choices.is_empty() {
            json["reset_choices"] = serde_json::json!(s.reset_choices);
        }
        json
    }
}

/// Called after each pass: (film so far, stats so far, seconds so far). Return `false` to stop.
pub type PassCallback<'a> = dyn FnMut(&Film, &Stats, f64) -> bool + Send + 'a;

/// Run `f` with its parallel parts (a scene load's BVH build) on `threads` workers, or on
/// rayon's global pool (every core) for `None`: a load keeps to the threads its render is given.
pub fn with_threads<T: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> T + Send,
) -> Result<T, String> {
    let Some(t) = threads else {
        return Ok(f());
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(t.max(1))
        .build()
        .map_err(|e| format!("cannot start worker threads: {e}"))?;
    Ok(pool.install(f))
}

/// Render `scene` with the integrator `kind`.
pub fn render(
    scene: &Scene,
    kind: IntegratorKind,
    opts: &IntegratorOptions,
    settings: &RenderSettings,
    on_pass: Option<&mut PassCallback>,
) -> Result<RenderOutput, String> {
    opts.validate_for(kind)?;
    if settings.spectral.is_some() {
        kind.spectral_support()?;
    }
    let pool = {
        let mut b = rayon::ThreadPoolBuilder::new();
        if let Some(t) = settings.threads {
            b = b.num_threads(t.max(1));
        }
        b.build()
            .map_err(|e| format!("cannot start worker threads: {e}"))?
    };
    pool.install(|| match kind {
        IntegratorKind::PtMono => run(
            scene,
            &super::pt::PtMono::new(scene, opts)?,
            settings,
            on_pass,
        ),
        IntegratorKind::PtHero => run(
            scene,
            &super::pt::PtHero::new(scene, opts)?,
            settings,
            on_pass,
        ),
        IntegratorKind::BdptForward => run(
            scene,
            &super::bdpt::Bdpt::new(scene, opts, super::bdpt::ResetMode::Forward)?,
            settings,
            on_pass,
        ),
        IntegratorKind::BdptBackward => run(
            scene,
            &super::bdpt::Bdpt::new(scene, opts, super::bdpt::ResetMode::Backward)?,
            settings,
            on_pass,
        ),
        IntegratorKind::BdptCombined => run(
            scene,
            &super::bdpt::Bdpt::combined(scene, opts)?,
            settings,
            on_pass,
        ),
        IntegratorKind::BdptAllbins => run(
            scene,
            &super::bdpt::allbins::BdptAllbins::new(scene, opts)?,
            settings,
            on_pass,
        ),
    })
}

/// What a film of the scene file `scene` (whose text is `scene_text`) rendered by `kind` with
/// `opts` and `seed` holds, samples `from..to`: the attributes its EXR carries. Strategy images
/// only add layers, so they are left out of the options a merge compares.
pub fn shard_info(
    scene: &std::path::Path,
    scene_text: &str,
    kind: IntegratorKind,
    opts: &IntegratorOptions,
    seed: u64,
    (from, to): (u32, u32),
) -> crate::film::shard::ShardInfo {
    let opts = IntegratorOptions {
        strategy_images: false,
        ..opts.clone()
    };
    crate::film::shard::ShardInfo {
        scene: scene.display().to_string(),
        scene_hash: crate::io::hash::text_hash(scene_text),
        integrator: kind.name().into(),
        options: serde_json::to_string(&opts).unwrap(),
        seed,
        from,
        to,
    }
}

/// Check, without rendering, that the integrator `kind` accepts `scene` with `opts`: validate the
/// options and construct the integrator (its `new` makes the checks), then drop it.
pub fn check(scene: &Scene, kind: IntegratorKind, opts: &IntegratorOptions) -> Result<(), String> {
    opts.validate_for(kind)?;
    match kind {
        IntegratorKind::PtMono => super::pt::PtMono::new(scene, opts).map(drop),
        IntegratorKind::PtHero => super::pt::PtHero::new(scene, opts).map(drop),
        IntegratorKind::BdptForward => {
            super::bdpt::Bdpt::new(scene, opts, super::bdpt::ResetMode::Forward).map(drop)
        }
        IntegratorKind::BdptBackward => {
            super::bdpt::Bdpt::new(scene, opts, super::bdpt::ResetMode::Backward).map(drop)
        }
        IntegratorKind::BdptCombined => super::bdpt::Bdpt::combined(scene, opts).map(drop),
        IntegratorKind::BdptAllbins => {
            super::bdpt::allbins::BdptAllbins::new(scene, opts).map(drop)
        }
    }
}

/// The integrator's scratch memory, one per worker thread of the pool, kept for the whole render
/// (its caches hold only pure functions of their keys, so which thread's copy a row uses does not
/// change the image). All are made before the first pass, on the calling thread: made lazily by
/// each worker instead, the 2-thread renders of bdpt-backward took 20–25 % more CPU time (perf
/// stat, three alternating runs).
struct Scratches<S>(Vec<Slot<S>>);

/// One worker's scratch on cache lines of its own: the structs hold the vectors' lengths, which
/// every sample writes, and two workers writing the same line would slow each other down.
#[repr(align(128))]
struct Slot<S>(Mutex<S>);

impl<S> Scratches<S> {
    fn new(make: impl Fn() -> S) -> Self {
        Scratches(
            (0..rayon::current_num_threads())
                .map(|_| Slot(Mutex::new(make())))
                .collect(),
        )
    }

    /// The calling worker's scratch (uncontended: a worker runs one row at a time).
    fn get(&self) -> MutexGuard<'_, S> {
        let i = rayon::current_thread_index().unwrap_or(0) % self.0.len();
        self.0[i].0.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// What a row leaves besides its pixel values, which go straight into the film; kept from pass
/// to pass, so that a pass allocates nothing once the buffers have grown. Each on cache lines of
/// its own: neighbouring rows run on different workers, and the statistics count every ray.
#[repr(align(128))]
struct RowResult {
    splats: Splats,
    aux: Vec<(u16, u32, Vec3)>,
    stats: Stats,
    /// Spectral light-tracing splats (pixel, bin, value).
    spectral_splats: Vec<(u32, u32, f32)>,
}

impl RowResult {
    fn new(width: u32, height: u32) -> Self {
        RowResult {
            splats: Splats::new(width, height),
            aux: Vec::new(),
            stats: Stats::default(),
            spectral_splats: Vec::new(),
        }
    }

    /// Empty, keeping the buffers' capacity.
    fn clear(&mut self) {
        self.splats.clear();
        self.aux.clear();
        self.spectral_splats.clear();
        let mut by_length = std::mem::take(&mut self.stats.contributing_by_length);
        by_length.clear();
        self.stats = Stats {
            contributing_by_length: by_length,
            ..Stats::default()
        };
    }
}

/// The rows of one pass: sample `s` of every pixel, rows in parallel. Each row adds its values
/// to its own film row (`sum`) and keeps its splats and strategy-image values in its
/// `RowResult` for [`add_splats`] and [`add_aux`].
fn pass_rows<I: Integrator>(
    scene: &Scene,
    integrator: &I,
    (seed, s): (u64, u32),
    (sum, spectral): (&mut [[f64; 3]], Option<&mut SpectralFilm>),
    rows: &mut [RowResult],
    scratches: &Scratches<I::Scratch>,
    cancel: Option<&Cancel>,
) {
    let (w, h) = (scene.camera.width, scene.camera.height);
    // The spectral image's rows beside the film's (empty rows without one).
    let bins = spectral.as_ref().map(|f| f.bins);
    let spectral_rows: Vec<&mut [f64]> = match spectral {
        Some(f) => f.sum.chunks_mut(f.bins.n * w as usize).collect(),
        None => (0..h).map(|_| &mut [][..]).collect(),
    };
    // One row per job: a thread that runs out steals single rows, so both threads stay busy to
    // the end of the pass (rayon's default leaves run up to a quarter of the rows in one piece,
    // which the other thread can only wait for).
    sum.par_chunks_mut(w as usize)
        .zip(rows.par_iter_mut())
        .zip(spectral_rows.into_par_iter())
        .enumerate()
        .with_max_len(1)
        .for_each(|(y, ((film_row, r), spectral_row))| {
            if cancelled(cancel) {
                // the render is abandoned: this pass's film is never read
                r.clear();
                return;
            }
            let mut scratch = scratches.get();
            let scratch = &mut *scratch;
            let y = y as u32;
            r.clear();
            for (x, sum) in (0..w).zip(film_row.iter_mut()) {
                let pixel = y * w + x;
                let mut sampler = Sampler::new(seed, pixel as u64, s as u64);
                let (jx, jy) = (sampler.next(), sampler.next());
                let spectral = bins.map(|bins| {
                    let n = bins.n;
                    SpectralSink {
                        bins,
                        inv_width: 1.0 / bins.width(),
                        own: &mut spectral_row[x as usize * n..(x as usize + 1) * n],
                        splats: &mut r.spectral_splats,
                    }
                });
                let mut sink = SampleSink {
                    value: Vec3::ZERO,
                    width: w,
                    height: h,
                    splats: &mut r.splats,
                    aux: &mut r.aux,
                    stats: &mut r.stats,
                    pixel,
                    spectral,
                };
                sink.stats.paths += 1;
                let (fx, fy) = (x as f32 + jx, y as f32 + jy);
                integrator.sample(scene, fx, fy, &mut sampler, scratch, &mut sink);
                Film::add(sum, sink.value);
            }
        });
}

/// Add the light-tracing splats of one pass's rows to the film's splat sums, by bands of film
/// rows in parallel and, within a band, in row order, so that every pixel receives its splats
/// in the same order whatever the thread count.
fn add_splats(splat: &mut [[f64; 3]], rows: &[RowResult], width: u32) {
    let band = (Splats::BAND_ROWS * width) as usize;
    if !rows
        .iter()
        .any(|r| r.splats.bands.iter().any(|b| !b.is_empty()))
    {
        return;
    }
    splat
        .par_chunks_mut(band)
        .enumerate()
        .with_max_len(1)
        .for_each(|(b, splat)| {
            let base = b * band;
            for r in rows {
                for (p, v) in &r.splats.bands[b] {
                    Film::add(&mut splat[*p as usize - base], *v);
                }
            }
        });
}

/// Add the strategy-image values, the spectral splats and the statistics of one pass's rows, in
/// row order.
fn add_aux(
    aux: &mut [Vec<[f64; 3]>],
    mut spectral: Option<&mut SpectralFilm>,
    rows: &[RowResult],
    stats: &mut Stats,
) {
    for r in rows {
        for (l, p, v) in &r.aux {
            Film::add(&mut aux[*l as usize][*p as usize], *v);
        }
        if let Some(f) = spectral.as_deref_mut() {
            let n = f.bins.n;
            for (p, b, v) in &r.spectral_splats {
                f.sum[*p as usize * n + *b as usize] += *v as f64;
            }
        }
        stats.merge(&r.stats);
    }
}

/// The progress bar of a render on a terminal (samples per pixel), `None` elsewhere.
fn progress_bar(settings: &RenderSettings) -> Option<indicatif::ProgressBar> {
    if !settings.progress || !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        return None;
    }
    let b = indicatif::ProgressBar::new(settings.spp as u64);
    b.set_style(
        indicatif::ProgressStyle::with_template(
            "{elapsed_precise} [{bar:40}] {pos}/{len} spp  eta {eta}  {msg}",
        )
        .unwrap()
        .progress_chars("=> "),
    );
    Some(b)
}

/// Run any integrator through the pass loop.
pub fn run<I: Integrator>(
    scene: &Scene,
    integrator: &I,
    settings: &RenderSettings,
    mut on_pass: Option<&mut PassCallback>,
) -> Result<RenderOutput, String> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let mut film = Film::new(w, h, integrator.aux_layers());
    if let Some(n) = settings.spectral {
        let bins = SpectralBins::new(scene.observer.range, n)?;
        film.spectral = Some(SpectralFilm::new(bins, (w * h) as usize));
    }
    // Two sets of row results: a pass's splats are added to the film while the next pass
    // renders into the other set (the adding scales poorly and would otherwise keep one thread
    // waiting at the end of every pass); each pixel still receives them pass by pass, in order.
    let mut rows: Vec<RowResult> = (0..h).map(|_| RowResult::new(w, h)).collect();
    let mut done: Vec<RowResult> = (0..h).map(|_| RowResult::new(w, h)).collect();
    let mut pending = false;
    let scratches = Scratches::new(|| integrator.scratch(scene));
    let mut stats = Stats::default();
    let start = Instant::now();
    let bar = progress_bar(settings);
    let end = settings
        .first_sample
        .checked_add(settings.spp)
        .ok_or_else(|| {
            format!(
                "samples {}..{}+{} exceed the largest sample index {}",
                settings.first_sample,
                settings.first_sample,
                settings.spp,
                u32::MAX
            )
        })?;
    let cancel = settings.cancel.as_ref();
    for s in settings.first_sample..end {
        if cancelled(cancel) {
            break;
        }
        let Film {
            sum,
            splat,
            aux,
            spectral,
            ..
        } = &mut film;
        let seed = settings.seed;
        let spectral_film = spectral.as_mut();
        rayon::join(
            || {
                let film = (sum.as_mut_slice(), spectral_film);
                pass_rows(
                    scene,
                    integrator,
                    (seed, s),
                    film,
                    &mut rows,
                    &scratches,
                    cancel,
                )
            },
            || {
                if pending {
                    add_splats(splat, &done, w);
                }
            },
        );
        add_aux(aux, spectral.as_mut(), &rows, &mut stats);
        std::mem::swap(&mut rows, &mut done);
        pending = true;
        film.spp += 1;
        if integrator.adapting() {
            // it learns from this pass's pixel values, splats included
            add_splats(&mut film.splat, &done, w);
            pending = false;
            integrator.end_pass(&film, &mut stats);
        }
        if on_pass.is_some() && pending {
            // the callback sees the film with this pass's splats
            add_splats(&mut film.splat, &done, w);
            pending = false;
        }
        let secs = start.elapsed().as_secs_f64();
        if let Some(b) = &bar {
            b.set_position(film.spp as u64);
            b.set_message(format!(
                "{:.2} Msamples/s",
                stats.paths as f64 / secs.max(1e-9) / 1e6
            ));
        }
        if let Some(cb) = on_pass.as_mut()
            && !cb(&film, &stats, secs)
        {
            break;
        }
        if settings.time_limit.is_some_and(|t| secs >= t) {
            break;
        }
    }
    if pending {
        add_splats(&mut film.splat, &done, w);
    }
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    if cancelled(cancel) {
        return Err(CANCELLED.into());
    }
    Ok(RenderOutput {
        film,
        stats,
        seconds: start.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::with_threads;

    /// A scene load run through `with_threads` sees that many workers (its BVH build's parallel
    /// parts run on them); `None` leaves it on the global pool.
    #[test]
    fn with_threads_gives_that_many_workers() {
        for n in [1, 3] {
            assert_eq!(with_threads(Some(n), rayon::current_num_threads), Ok(n));
        }
        let all = rayon::current_num_threads();
        assert_eq!(with_threads(None, rayon::current_num_threads), Ok(all));
    }
}
