//! The `wavrad` command: parse arguments → load the scene → solve → write the
//! image and statistics. Option strings become core enums here; everything
//! else lives in `wavrad-core` and `wavrad-io`.

use clap::{Args, Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Mutex;
use std::time::Instant;
use wavrad_core::progress::Progress;
use wavrad_core::refine::oracle::Oracle;
use wavrad_core::render::reconstruct::Reconstruction;
use wavrad_core::render::RenderSettings;
use wavrad_core::solve::shoot::{solve_shooting, Step};
use wavrad_core::solve::{solve, Solution, SolveSettings, Solver};

/// Haar-wavelet global illumination (Pattanaik & Bouatouch 1994) for Mitsuba 3
/// XML scenes.
#[derive(Parser, Debug)]
#[command(name = "wavrad", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Solve the scene and render its sensor to an EXR (linear) or PNG (sRGB) image.
    Render {
        #[command(flatten)]
        solve: SolveArgs,
        /// Output image; the extension (.exr or .png) chooses the format.
        #[arg(short, long)]
        output: PathBuf,
        /// How radiance is reconstructed on surfaces (default: the most accurate).
        #[arg(long, value_enum, default_value_t = Mode::Gather)]
        mode: Mode,
        /// Camera rays per pixel where an edge shows [default: 256, or the
        /// scene sampler's sample_count if larger]; pixels that show one
        /// surface (as do their neighbours) get a quarter.
        #[arg(long)]
        spp: Option<u32>,
        /// Of an interior pixel's camera rays, how many also final-gather,
        /// each with 4 shadow rays per emitter and 32 indirect rays (gather
        /// mode) [default: an eighth]; other pixels gather in the same
        /// proportion, with fewer indirect rays each, and a caustic's
        /// receivers (diffuse surfaces facing a sharp glossy surface that
        /// mirrors an emitter) eight times as much (as more indirect rays
        /// per gather where there are fewer camera rays than that).
        #[arg(long)]
        gather_spp: Option<u32>,
        /// Outside gather mode, read glossy surfaces' radiance from the
        /// view-independent solution (directional radiance towards what the
        /// view ray meets beyond the eye, or towards an enclosure receiver
        /// around the scene) instead of gathering once into the eye: no
        /// per-view work, softer highlights.
        #[arg(long)]
        no_eye: bool,
        /// In gather mode, gather once per texel of every diffuse surface
        /// (view-independent; texels half an element wide) and read the
        /// texels, instead of gathering per camera ray: for many views of
        /// one solution.
        #[arg(long)]
        gather_cache: bool,
    },
    /// Solve the scene (view-independent) and report statistics, without an image.
    Solve {
        #[command(flatten)]
        solve: SolveArgs,
    },
    /// Print the relative RMSE, sqrt(mean((a-b)^2))/mean(b), of an EXR image
    /// against an EXR reference of the same size.
    Compare {
        /// Image to judge.
        image: PathBuf,
        /// Reference (e.g. a path-traced render).
        reference: PathBuf,
    },
}

#[derive(Args, Debug)]
struct SolveArgs {
    /// Mitsuba 3 XML scene.
    scene: PathBuf,
    /// Refinement oracle: `kernel` (the paper's: Haar details of the kernel
    /// alone), `power` (kernel variation × radiance carried, Hanrahan et al.
    /// 1991) or `importance` (power × the receiver's importance for the
    /// scene's sensor, Smits et al. 1992). The last two run a refine–solve
    /// loop.
    #[arg(long, default_value = "kernel", value_parser = parse_oracle)]
    oracle: Oracle,
    /// How the radiance system is solved: `gather` (every kernel projected
    /// up front, then Gauss–Seidel gathering; the paper's §4.2) or `shoot`
    /// (progressive shooting from the emitters, kernels projected only where
    /// light flows; the paper's §6; diffuse scenes only for now).
    #[arg(long, default_value = "gather", value_parser = parse_solver)]
    solver: Solver,
    /// With `--solver shoot`: after every shooting step, write a quick image
    /// of the solution so far (smooth reconstruction, 4 rays per pixel, the
    /// scene's sensor) to DIR/step-0001.exr, DIR/step-0002.exr, ...
    #[arg(long, value_name = "DIR")]
    progressive: Option<PathBuf>,
    /// Oracle threshold. Kernel oracle: on the kernel's Haar detail
    /// coefficients in the paper's orthonormal normalisation (the paper uses
    /// 1e-4) [default: 1e-3]. Weighted oracles: on the estimated error of a
    /// receiver's radiance relative to the brightest emission [default: see
    /// README].
    #[arg(long)]
    threshold: Option<f64>,
    /// Most projections of the refine–solve loop of the weighted oracles.
    #[arg(long)]
    refine_passes: Option<u32>,
    /// Maximum subdivision level of an element (the paper uses 8).
    #[arg(long)]
    max_level: Option<u32>,
    /// Maximum subdivision level of the elements of three-point (glossy)
    /// links [default: 2].
    #[arg(long)]
    three_point_max_level: Option<u32>,
    /// Levels the receiving element of a three-point link may go below
    /// --three-point-max-level: sharper highlights on diffuse receivers
    /// for no extra ray queries [default: 0].
    #[arg(long)]
    three_point_receiver_levels: Option<u32>,
    /// Oracle threshold of three-point (glossy) links [default: 1e-5].
    #[arg(long)]
    three_point_threshold: Option<f64>,
    /// Write statistics (counts per level, times, memory) as JSON to this file.
    #[arg(long)]
    stats: Option<PathBuf>,
    /// Set a scene parameter declared with `<default>`, as NAME=VALUE (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    define: Vec<String>,
}

#[derive(ValueEnum, Clone, Copy, Debug)]
enum Mode {
    /// Piecewise-constant Haar projection, as solved.
    Haar,
    /// Smooth reconstruction (linear spline dual of the Haar basis); glossy
    /// surfaces smoothly from their radiance towards the eye.
    Smooth,
    /// The solution looked up along view rays: smooth on diffuse surfaces,
    /// glossy ones from their directional radiance towards the eye.
    Direct,
    /// Final gather per pixel over the solution (the most accurate): exact
    /// direct light plus the smooth solution on diffuse surfaces, light and
    /// BRDF sampling over the solution on glossy ones.
    Gather,
}

/// Progress bars on a terminal, nothing otherwise.
struct Bars {
    enabled: bool,
    bar: Mutex<Option<ProgressBar>>,
}

impl Progress for Bars {
    fn start(&self, phase: &str, total: u64) {
        if !self.enabled {
            return;
        }
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template("{msg:>9} [{bar:40}] {pos}/{len} {elapsed_precise}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        bar.set_message(phase.to_string());
        *self.bar.lock().expect("progress lock") = Some(bar);
    }
    fn advance(&self, steps: u64) {
        if let Some(bar) = self.bar.lock().expect("progress lock").as_ref() {
            bar.inc(steps);
        }
    }
    fn finish(&self) {
        if let Some(bar) = self.bar.lock().expect("progress lock").take() {
            bar.finish_and_clear();
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("wavrad: error: {message}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<(), String> {
    let progress = Bars {
        enabled: std::io::stderr().is_terminal(),
        bar: Mutex::new(None),
    };
    match cli.command {
        Command::Compare { image, reference } => {
            let (w, h, a) = wavrad_io::read_exr_rgb(&image).map_err(|e| e.to_string())?;
            let (rw, rh, b) = wavrad_io::read_exr_rgb(&reference).map_err(|e| e.to_string())?;
            if (w, h) != (rw, rh) {
                return Err(format!(
                    "{} is {w}x{h} but {} is {rw}x{rh}",
                    image.display(),
                    reference.display()
                ));
            }
            println!("relative RMSE {:.5}", wavrad_io::relative_rmse(&a, &b));
            Ok(())
        }
        Command::Solve { solve: args } => {
            let solution = load_and_solve(&args, &progress)?;
            report(&solution, None);
            write_stats(&args, &solution)
        }
        Command::Render {
            solve: args,
            output,
            mode,
            spp,
            gather_spp,
            no_eye,
            gather_cache,
        } => {
            check_output_extension(&output)?;
            let mut solution = load_and_solve(&args, &progress)?;
            let mut settings = RenderSettings::for_scene(&solution.scene);
            if let Some(n) = spp {
                settings = settings.with_samples_per_pixel(n);
            }
            if let Some(n) = gather_spp {
                settings.gather_samples_per_pixel = n.max(1);
            }
            settings.eye = !no_eye;
            settings.gather_cache = gather_cache;
            settings.mode = match mode {
                Mode::Haar => Reconstruction::Haar,
                Mode::Smooth => Reconstruction::Smooth,
                Mode::Direct => Reconstruction::Direct,
                Mode::Gather => Reconstruction::Gather,
            };
            let clock = Instant::now();
            let image = solution
                .render(&settings)
                .map_err(|e| format!("{}: {e}", args.scene.display()))?;
            solution.stats.times.render_s = clock.elapsed().as_secs_f64();
            solution.stats.peak_memory_bytes = wavrad_core::solve::stats::peak_memory_bytes();
            wavrad_io::write_image(&output, image.width, image.height, &image.rgb)
                .map_err(|e| e.to_string())?;
            report(&solution, Some(&output));
            write_stats(&args, &solution)
        }
    }
}

fn load_and_solve(args: &SolveArgs, progress: &Bars) -> Result<Solution, String> {
    let defines = args
        .define
        .iter()
        .map(|d| {
            d.split_once('=')
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .ok_or_else(|| format!("-D expects NAME=VALUE, got {d:?}"))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let scene = wavrad_io::load_scene_with(&args.scene, &defines).map_err(|e| e.to_string())?;
    let mut settings = SolveSettings::for_oracle(args.oracle);
    if let Some(n) = args.refine_passes {
        settings.max_refine_passes = n;
    }
    if let Some(t) = args.threshold {
        settings.refine.threshold = t;
    }
    if let Some(j) = args.max_level {
        settings.refine.max_level = j;
    }
    if let Some(j) = args.three_point_max_level {
        settings.three_point_max_level = j;
    }
    if let Some(j) = args.three_point_receiver_levels {
        settings.three_point_receiver_levels = j;
    }
    if let Some(t) = args.three_point_threshold {
        settings.three_point_threshold = t;
    }
    let in_scene = |e: wavrad_core::Error| format!("{}: {e}", args.scene.display());
    match (args.solver, &args.progressive) {
        (Solver::Gather, None) => solve(&scene, &settings, progress).map_err(in_scene),
        (Solver::Gather, Some(_)) => Err("--progressive needs --solver shoot".into()),
        (Solver::Shoot, None) => {
            solve_shooting(&scene, &settings, progress, None).map_err(in_scene)
        }
        (Solver::Shoot, Some(dir)) => {
            if scene.camera.is_none() {
                return Err(format!(
                    "{}: --progressive renders the scene's sensor, and the scene has no sensor",
                    args.scene.display()
                ));
            }
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            let mut failure = None;
            let mut on_step = |solution: &Solution, step: &Step| {
                let written = write_progressive_image(solution, step, dir);
                failure = written.err();
                match failure {
                    Some(_) => ControlFlow::Break(()),
                    None => ControlFlow::Continue(()),
                }
            };
            let solution = solve_shooting(&scene, &settings, progress, Some(&mut on_step))
                .map_err(in_scene)?;
            match failure {
                Some(e) => Err(e),
                None => Ok(solution),
            }
        }
    }
}

/// One progressive image: the solution after `step`, smoothly reconstructed
/// with few camera rays.
fn write_progressive_image(solution: &Solution, step: &Step, dir: &Path) -> Result<(), String> {
    let image = solution.preview().map_err(|e| e.to_string())?;
    let path = dir.join(format!("step-{:04}.exr", step.index));
    wavrad_io::write_image(&path, image.width, image.height, &image.rgb).map_err(|e| e.to_string())
}

fn parse_oracle(s: &str) -> Result<Oracle, String> {
    s.parse()
}

fn parse_solver(s: &str) -> Result<Solver, String> {
    s.parse()
}

fn check_output_extension(output: &Path) -> Result<(), String> {
    match output
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("exr" | "png") => Ok(()),
        _ => Err(format!(
            "{}: unsupported image format (supported extensions: .exr, .png)",
            output.display()
        )),
    }
}

fn report(solution: &Solution, output: Option<&Path>) {
    let s = &solution.stats;
    let t = &s.times;
    eprintln!(
        "wavrad: {} surfaces, {} two-point nodes, {} two-point interactions; {} iterations (residual {:.2e}); \
         kernels {:.2}s, solve {:.2}s, render {:.2}s",
        s.surfaces,
        s.two_point_nodes,
        s.two_point_interactions,
        s.iterations,
        s.residual,
        t.kernels_s,
        t.solve_s,
        t.render_s
    );
    if s.shooting_steps > 0 {
        eprintln!(
            "wavrad: {} shooting steps (unshot {:.2e} of the emitted power); kernels projected for \
             {} of {} surface pairs",
            s.shooting_steps, s.unshot_fraction, s.kernel_pairs, s.exchanging_pairs
        );
    }
    if let Some(out) = output {
        eprintln!("wavrad: wrote {}", out.display());
    }
}

fn write_stats(args: &SolveArgs, solution: &Solution) -> Result<(), String> {
    let Some(path) = &args.stats else {
        return Ok(());
    };
    let mut json = serde_json::to_value(&solution.stats).map_err(|e| e.to_string())?;
    json["scene"] = serde_json::Value::String(args.scene.display().to_string());
    let text = serde_json::to_string_pretty(&json).map_err(|e| e.to_string())?;
    wavrad_io::write_atomic(path, text.as_bytes()).map_err(|e| e.to_string())
}
