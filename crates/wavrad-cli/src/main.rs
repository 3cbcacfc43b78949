//! The `wavrad` command: parse arguments → load the scene → solve → write the
//! image and statistics. Option strings become core enums here; everything
//! else lives in `wavrad-core` and `wavrad-io`.

use clap::{Arg, ArgAction, ArgMatches, Args, FromArgMatches, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::marker::PhantomData;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use wavrad_core::progress::Progress;
use wavrad_core::render::{RenderSettings, Renderer};
use wavrad_core::scene::Scene;
use wavrad_core::setting::{Described, Domain, Group, Value};
use wavrad_core::solve::shoot::{solve_shooting, Step};
use wavrad_core::solve::{solve_saving, CheckpointView, Saver, Solution, SolveSettings, Solver};
use wavrad_io::solution_file::{
    read_solution, read_unfinished, write_checkpoint, write_solution, Source,
};

/// Haar-wavelet global illumination (Pattanaik & Bouatouch 1994) for Mitsuba 3
/// XML scenes.
#[derive(Parser, Debug)]
#[command(name = "wavrad", version, about)]
struct Cli {
    /// Print no progress and no summary (warnings and errors still show).
    #[arg(short, long, global = true)]
    quiet: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Solve the scene, or read a solution written by `wavrad solve -o`,
    /// and render its sensor to an EXR (linear) or PNG (sRGB) image.
    Render {
        #[command(flatten)]
        solve: SolveArgs,
        /// Output image; the extension (.exr or .png) chooses the format.
        #[arg(short, long, help_heading = "Output options")]
        output: PathBuf,
        /// Which of the scene's sensors to render, numbered from 0 in the
        /// scene file's order [default: 0, the first].
        #[arg(long, value_name = "N", help_heading = "Output options")]
        sensor: Option<usize>,
        #[command(flatten)]
        settings: Given<RenderSettings>,
    },
    /// Solve the scene (view-independent) and report statistics; with
    /// `-o`, write the solution to render later without solving again.
    Solve {
        #[command(flatten)]
        solve: SolveArgs,
        /// Write the solution to this file (.wavrad); `wavrad render FILE.wavrad`
        /// renders it.
        #[arg(short, long, help_heading = "Output options")]
        output: Option<PathBuf>,
        /// Resume the solve written to this solution file (.wavrad) when a
        /// limit or Ctrl-C cut it short, or saved to a checkpoint file
        /// (NAME.checkpoint.wavrad) before the process was killed: the
        /// items it refined are kept, only those it left are refined, then
        /// the solution is finished as an uninterrupted solve's. Its
        /// settings are kept (a setting that changes refinement may not
        /// differ); --time-limit and --max-memory are this run's own.
        #[arg(long, value_name = "FILE", help_heading = Group::Solve.heading())]
        resume: Option<PathBuf>,
        /// With -o NAME.wavrad, save what the kernel projection has
        /// finished to NAME.checkpoint.wavrad at most every SECONDS, for
        /// --resume after the process is killed (removed once the solution
        /// is written); 0: never.
        #[arg(
            long,
            value_name = "SECONDS",
            default_value_t = 300.0,
            help_heading = "Output options"
        )]
        checkpoint_every: f64,
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
    /// Mitsuba 3 XML scene; for `render`, also a solution file (.wavrad)
    /// written by `wavrad solve -o`, rendered without solving again.
    scene: PathBuf,
    /// Set a scene parameter declared with `<default>`, as NAME=VALUE (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE", help_heading = "Scene options")]
    define: Vec<String>,
    /// Replace every unsupported BSDF or texture (anisotropic rough glass,
    /// `principled` with transmission, `normalmap`, …) by the nearest supported model, with one warning per
    /// plugin saying what was substituted, instead of refusing the scene.
    #[arg(long, help_heading = "Scene options")]
    approximate: bool,
    /// How the radiance system is solved: `gather` (every kernel projected
    /// up front, then Gauss–Seidel gathering; the paper's §4.2) or `shoot`
    /// (progressive shooting from the emitters, kernels projected only where
    /// light flows; the paper's §6; diffuse scenes only for now) [default:
    /// gather].
    #[arg(long, value_parser = |s: &str| s.parse::<Solver>(), help_heading = Group::Solve.heading())]
    solver: Option<Solver>,
    #[command(flatten)]
    settings: Given<SolveSettings>,
    /// With `--solver shoot`: after every shooting step, write a quick image
    /// of the solution so far (smooth reconstruction, 4 rays per pixel, the
    /// scene's sensor) to DIR/step-0001.exr, DIR/step-0002.exr, ...
    #[arg(long, value_name = "DIR", help_heading = "Output options")]
    progressive: Option<PathBuf>,
    /// Write statistics (counts per level, times, memory, settings) as JSON to this file.
    #[arg(long, help_heading = "Output options")]
    stats: Option<PathBuf>,
}

/// The settings of `S` given on the command line, by name: one option per
/// setting its description lists ([`Described::SETTINGS`]), under the
/// setting's group, with its default in the help.
#[derive(Debug)]
struct Given<S> {
    values: Vec<(&'static str, Value)>,
    described: PhantomData<S>,
}

impl<S: Described> FromArgMatches for Given<S> {
    fn from_arg_matches(matches: &ArgMatches) -> Result<Self, clap::Error> {
        let values = S::SETTINGS
            .iter()
            .filter_map(|s| match s.domain {
                Domain::Flag => matches
                    .get_flag(s.name)
                    .then_some((s.name, Value::Flag(s.default != "true"))),
                _ => matches.get_one::<Value>(s.name).map(|&v| (s.name, v)),
            })
            .collect();
        Ok(Given {
            values,
            described: PhantomData,
        })
    }

    fn update_from_arg_matches(&mut self, matches: &ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(matches)?;
        Ok(())
    }
}

impl<S: Described> Args for Given<S> {
    fn augment_args(command: clap::Command) -> clap::Command {
        S::SETTINGS.iter().fold(command, |command, setting| {
            let long = setting.flag().trim_start_matches('-').to_string();
            let arg = Arg::new(setting.name).help_heading(setting.group.heading());
            // A flag is given to change it: `--no-NAME` where it is on by default.
            let arg = match setting.domain {
                Domain::Flag if setting.default == "true" => arg
                    .long(format!("no-{long}"))
                    .action(ArgAction::SetTrue)
                    .help(format!(
                        "{} [default: on; this flag turns it off]",
                        setting.help
                    )),
                Domain::Flag => arg.long(long).action(ArgAction::SetTrue).help(setting.help),
                domain => arg
                    .long(long)
                    .value_name(match domain {
                        Domain::Real { .. } => "X",
                        Domain::Choice(_) => "NAME",
                        _ => "N",
                    })
                    .help(format!("{} [default: {}]", setting.help, setting.default))
                    .value_parser(move |text: &str| setting.parse(text)),
            };
            command.arg(arg)
        })
    }

    fn augment_args_for_update(command: clap::Command) -> clap::Command {
        Self::augment_args(command)
    }
}

/// How progress is shown: bars on a terminal, plain lines otherwise (a
/// log, CI), nothing with `--quiet`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Show {
    Bars,
    Lines,
    Nothing,
}

/// Seconds between two plain progress lines of one phase.
const LINE_INTERVAL_S: f64 = 10.0;

/// One phase under way.
struct Phase {
    name: String,
    total: u64,
    done: u64,
    started: Instant,
    /// When the last plain line was printed.
    printed: Instant,
    bar: Option<ProgressBar>,
}

/// The CLI's progress: each phase as a bar with its rate and time left, or
/// as a plain line every [`LINE_INTERVAL_S`]; Ctrl-C asks the solve to
/// stop ([`Progress::interrupted`]).
struct Reporter {
    show: Show,
    phase: Arc<Mutex<Option<Phase>>>,
    interrupted: Arc<AtomicBool>,
}

impl Phase {
    /// The plain line of this phase now: done of total, time so far and,
    /// once something is done, the time left at this rate.
    fn line(&mut self) -> String {
        self.printed = Instant::now();
        let elapsed = self.started.elapsed().as_secs_f64();
        let share = self.done as f64 / self.total.max(1) as f64;
        let mut line = format!(
            "wavrad: {} {}/{} ({:.0} %), {:.0} s",
            self.name,
            self.done,
            self.total,
            100.0 * share,
            elapsed
        );
        if self.done > 0 {
            let left = elapsed * (1.0 - share) / share;
            line += &format!(", about {left:.0} s left");
        }
        line
    }

    /// Whether a plain line is due.
    fn line_due(&self) -> bool {
        self.bar.is_none() && self.printed.elapsed().as_secs_f64() >= LINE_INTERVAL_S
    }
}

impl Reporter {
    fn new(quiet: bool) -> Reporter {
        let show = match (quiet, std::io::stderr().is_terminal()) {
            (true, _) => Show::Nothing,
            (false, true) => Show::Bars,
            (false, false) => Show::Lines,
        };
        let reporter = Reporter {
            show,
            phase: Arc::new(Mutex::new(None)),
            interrupted: Arc::new(AtomicBool::new(false)),
        };
        if show == Show::Lines {
            reporter.print_lines_while_silent();
        }
        reporter
    }

    /// Plain lines keep coming while a phase advances too slowly to print
    /// them itself (a few surface pairs refined for minutes each): a thread
    /// looks every second whether a line is due.
    fn print_lines_while_silent(&self) {
        let phase = Arc::clone(&self.phase);
        std::thread::spawn(move || loop {
            std::thread::sleep(Duration::from_secs(1));
            let mut phase = phase.lock().expect("progress lock");
            if let Some(phase) = phase.as_mut().filter(|p| p.line_due()) {
                eprintln!("{}", phase.line());
            }
        });
    }

    /// A note between phases (loading, writing), unless quiet.
    fn note(&self, text: &str) {
        if self.show == Show::Nothing {
            return;
        }
        let phase = self.phase.lock().expect("progress lock");
        match phase.as_ref().and_then(|p| p.bar.as_ref()) {
            // Above the bar, which goes on below.
            Some(bar) => bar.println(format!("wavrad: {text}")),
            None => eprintln!("wavrad: {text}"),
        }
    }

    /// First Ctrl-C: the solve stops refining and sweeping and finishes
    /// from what is done; a second one quits at once.
    fn stop_on_ctrl_c(&self) {
        let interrupted = Arc::clone(&self.interrupted);
        let handler = ctrlc::set_handler(move || {
            if interrupted.swap(true, Ordering::SeqCst) {
                eprintln!("\nwavrad: interrupted again: quitting, nothing more is written");
                std::process::exit(130);
            }
            eprintln!(
                "\nwavrad: interrupted: the solve stops refining and finishes from what is done \
                 (Ctrl-C again quits at once)"
            );
        });
        if let Err(e) = handler {
            eprintln!("wavrad: warning: Ctrl-C will quit at once: {e}");
        }
    }

    fn was_interrupted(&self) -> bool {
        self.interrupted.load(Ordering::SeqCst)
    }
}

impl Progress for Reporter {
    fn start(&self, name: &str, total: u64) {
        if self.show == Show::Nothing {
            return;
        }
        let bar = (self.show == Show::Bars).then(|| {
            let bar = ProgressBar::new(total);
            bar.set_style(
                ProgressStyle::with_template(
                    "{msg:>15} [{bar:30}] {pos}/{len} {per_sec} {elapsed_precise}, {eta} left",
                )
                .expect("valid template")
                .progress_chars("=> "),
            );
            bar.set_message(name.to_string());
            bar
        });
        let now = Instant::now();
        *self.phase.lock().expect("progress lock") = Some(Phase {
            name: name.to_string(),
            total,
            done: 0,
            started: now,
            printed: now,
            bar,
        });
    }

    fn advance(&self, steps: u64) {
        let mut phase = self.phase.lock().expect("progress lock");
        let Some(phase) = phase.as_mut() else {
            return;
        };
        phase.done += steps;
        if let Some(bar) = &phase.bar {
            bar.inc(steps);
        } else if phase.line_due() {
            eprintln!("{}", phase.line());
        }
    }

    fn finish(&self) {
        let Some(phase) = self.phase.lock().expect("progress lock").take() else {
            return;
        };
        match phase.bar {
            Some(bar) => bar.finish_and_clear(),
            None if phase.started.elapsed().as_secs_f64() >= LINE_INTERVAL_S => eprintln!(
                "wavrad: {} done ({}), {:.1} s",
                phase.name,
                phase.done,
                phase.started.elapsed().as_secs_f64()
            ),
            None => {}
        }
    }

    fn interrupted(&self) -> bool {
        self.was_interrupted()
    }

    fn warn(&self, message: &str) {
        let phase = self.phase.lock().expect("progress lock");
        match phase.as_ref().and_then(|p| p.bar.as_ref()) {
            Some(bar) => bar.println(format!("wavrad: warning: {message}")),
            None => eprintln!("wavrad: warning: {message}"),
        }
    }
}

/// The reporter's progress for a render: the bars, but not the interrupt,
/// which stops the solve and, pressed again, quits (a render stopped half
/// way has nothing to finish).
struct Rendering<'a>(&'a Reporter);

impl Progress for Rendering<'_> {
    fn start(&self, phase: &str, total: u64) {
        self.0.start(phase, total)
    }
    fn advance(&self, steps: u64) {
        self.0.advance(steps)
    }
    fn finish(&self) {
        self.0.finish()
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let progress = Reporter::new(cli.quiet);
    progress.stop_on_ctrl_c();
    match run(cli, &progress) {
        // An interrupted run finished what it could, and says so by its status.
        Ok(()) if progress.was_interrupted() => ExitCode::from(130),
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("wavrad: error: {message}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli, progress: &Reporter) -> Result<(), String> {
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
        Command::Solve {
            solve: args,
            output,
            resume,
            checkpoint_every,
        } => {
            if is_solution_file(&args.scene) {
                return Err(format!(
                    "{}: a solution file is rendered (`wavrad render {0} -o IMAGE`), not solved",
                    args.scene.display()
                ));
            }
            if let Some(output) = &output {
                check_solution_extension(output)?;
            }
            if let Some(resume) = &resume {
                check_solution_extension(resume)?;
            }
            check_outputs(output.as_deref(), args.stats.as_deref())?;
            let checkpoints = checkpoint_path(output.as_deref(), checkpoint_every)?;
            if let Some(checkpoints) = &checkpoints {
                wavrad_io::check_writable(checkpoints).map_err(|e| e.to_string())?;
                if checkpoints.exists() && resume.as_deref() != Some(checkpoints.as_path()) {
                    eprintln!(
                        "wavrad: warning: {0} is the checkpoint of an earlier solve that did not \
                         finish; this solve starts over and replaces it (`--resume {0}` would \
                         have gone on from it)",
                        checkpoints.display()
                    );
                }
            }
            let saving = checkpoints.as_deref().map(|path| (path, checkpoint_every));
            let (solution, source) = load_and_solve(&args, resume.as_deref(), saving, progress)?;
            report(&solution, None, progress);
            if let Some(output) = &output {
                progress.note(&format!("writing {}", output.display()));
                write_solution(output, &solution, Some(&source)).map_err(|e| e.to_string())?;
                progress.note(&format!("wrote {}", output.display()));
            }
            // The solution (with its own checkpoint, if cut short) replaces
            // the saved checkpoint, even the one resumed from.
            if let Some(path) = checkpoints {
                match std::fs::remove_file(&path) {
                    Err(e) if e.kind() != std::io::ErrorKind::NotFound => eprintln!(
                        "wavrad: warning: {}: could not remove the checkpoint: {e}",
                        path.display()
                    ),
                    _ => {}
                }
            }
            if solution.checkpoint.is_some() {
                let scene = args.scene.display();
                progress.note(&match &output {
                    Some(output) => format!(
                        "to finish the solve: wavrad solve {scene} --resume {} -o NEW.wavrad",
                        output.display()
                    ),
                    None => "the solve can be resumed only from a solution file (-o)".into(),
                });
            }
            write_stats(&args, &solution, None)
        }
        Command::Render {
            solve: args,
            output,
            sensor,
            settings,
        } => {
            check_output_extension(&output)?;
            check_outputs(Some(&output), args.stats.as_deref())?;
            // Options that do not go together, or a sensor the scene does
            // not have, fail before the solve.
            RenderSettings::from_values(&Default::default(), &settings.values)
                .map_err(|e| e.to_string())?;
            let in_scene = |e: wavrad_core::Error| format!("{}: {e}", args.scene.display());
            let sensor = sensor.unwrap_or(0);
            let solution = if is_solution_file(&args.scene) {
                read_solution_file(&args, progress)?
            } else {
                let (scene, _) = load(&args, progress)?;
                scene.sensor(sensor).map_err(in_scene)?;
                solve_loaded(&args, &scene, None, None, progress)?
            };
            let sensor = solution.scene.sensor(sensor).map_err(in_scene)?;
            let settings = RenderSettings::from_values(&sensor.hints, &settings.values)
                .map_err(|e| e.to_string())?;
            let renderer = Renderer::new(solution);
            let clock = Instant::now();
            let image = renderer
                .render_view(
                    &sensor.camera,
                    &sensor.film,
                    &settings,
                    &Rendering(progress),
                )
                .map_err(in_scene)?;
            let mut solution = renderer.into_solution();
            solution.stats.times.render_s = clock.elapsed().as_secs_f64();
            solution.stats.peak_memory_bytes = wavrad_core::solve::stats::peak_memory_bytes();
            progress.note(&format!("writing {}", output.display()));
            wavrad_io::write_image(&output, image.width, image.height, &image.rgb)
                .map_err(|e| e.to_string())?;
            report(&solution, Some(&output), progress);
            write_stats(&args, &solution, Some(&settings))
        }
    }
}

/// Whether `path` names a solution file (by its extension, .wavrad), to be
/// read rather than solved.
fn is_solution_file(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case(SOLUTION_EXTENSION))
}

/// The extension of solution files.
const SOLUTION_EXTENSION: &str = "wavrad";

fn check_solution_extension(path: &Path) -> Result<(), String> {
    if is_solution_file(path) {
        Ok(())
    } else {
        Err(format!(
            "{}: a solution file's name ends in .{SOLUTION_EXTENSION}",
            path.display()
        ))
    }
}

/// The solution in the file `args.scene`, with its warnings shown; the
/// options of a solve are refused, since nothing is solved.
fn read_solution_file(args: &SolveArgs, progress: &Reporter) -> Result<Solution, String> {
    let solving = [
        (!args.define.is_empty()).then_some("-D"),
        args.approximate.then_some("--approximate"),
        args.solver.map(|_| "--solver"),
        args.progressive.as_ref().map(|_| "--progressive"),
    ];
    let given = solving
        .into_iter()
        .flatten()
        .map(str::to_string)
        .chain(
            args.settings
                .values
                .iter()
                .map(|(name, _)| format!("--{}", name.replace('_', "-"))),
        )
        .collect::<Vec<_>>();
    if !given.is_empty() {
        return Err(format!(
            "{}: a solution file is rendered as it was solved; {} belong to `wavrad solve`",
            args.scene.display(),
            given.join(", ")
        ));
    }
    progress.note(&format!("reading {}", args.scene.display()));
    let read = read_solution(&args.scene).map_err(|e| e.to_string())?;
    for warning in &read.warnings {
        eprintln!("wavrad: warning: {warning}");
    }
    if let (Some(stop), Some(_)) = (read.solution.stats.stopped, &read.solution.checkpoint) {
        eprintln!(
            "wavrad: warning: {}: {stop} cut this solve short ({} surface pairs, triples or \
             links left unrefined); `wavrad solve SCENE --resume {0}` finishes it",
            args.scene.display(),
            read.solution.stats.unrefined_items
        );
    }
    Ok(read.solution)
}

/// The checkpoint file of the solution file `output` (NAME.wavrad:
/// NAME.checkpoint.wavrad) when checkpoints are saved every `every`
/// seconds.
fn checkpoint_path(output: Option<&Path>, every: f64) -> Result<Option<PathBuf>, String> {
    if !(every.is_finite() && every >= 0.0) {
        return Err(format!("--checkpoint-every is {every}: seconds, 0 or more"));
    }
    Ok(output.filter(|_| every > 0.0).map(|output| {
        let stem = output.file_stem().unwrap_or_default().to_string_lossy();
        output.with_file_name(format!("{stem}.checkpoint.{SOLUTION_EXTENSION}"))
    }))
}

/// Load the scene of `args` and solve it, or resume the solve in the
/// solution or checkpoint file `resume` ([`wavrad_core::solve::resume`]),
/// saving checkpoints to `saving`'s file every `saving`'s seconds; with
/// where it came from, for a solution file.
fn load_and_solve(
    args: &SolveArgs,
    resume: Option<&Path>,
    saving: Option<(&Path, f64)>,
    progress: &Reporter,
) -> Result<(Solution, Source), String> {
    let (scene, source) = load(args, progress)?;
    // A failed save is reported once; the solve goes on.
    let failed = AtomicBool::new(false);
    let save = |scene: &Scene, settings: &SolveSettings, view: CheckpointView<'_>| {
        let Some((path, _)) = saving else { return };
        let (finished, items) = (view.finished_items(), view.items);
        match write_checkpoint(path, scene, settings, view, Some(&source)) {
            Ok(()) => progress.note(&format!(
                "saved a checkpoint ({finished} of {items} items projected) to {}",
                path.display()
            )),
            Err(e) if !failed.swap(true, Ordering::SeqCst) => {
                eprintln!("wavrad: warning: the checkpoint could not be saved: {e}")
            }
            Err(_) => {}
        }
    };
    let saver = saving.map(|(_, every)| Saver {
        every: Duration::from_secs_f64(every),
        save: &save,
    });
    let solution = solve_loaded(args, &scene, resume, saver.as_ref(), progress)?;
    Ok((solution, source))
}

/// The scene of `args`, loaded with its warnings shown, and where it came
/// from.
fn load(args: &SolveArgs, progress: &Reporter) -> Result<(Scene, Source), String> {
    let defines = args
        .define
        .iter()
        .map(|d| {
            d.split_once('=')
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .ok_or_else(|| format!("-D expects NAME=VALUE, got {d:?}"))
        })
        .collect::<Result<Vec<_>, _>>()?;
    progress.note(&format!("loading {}", args.scene.display()));
    let options = wavrad_io::LoadOptions {
        approximate: args.approximate,
    };
    let loaded = wavrad_io::load_scene_with_options(&args.scene, &defines, options)
        .map_err(|e| e.to_string())?;
    for warning in &loaded.warnings {
        eprintln!("wavrad: warning: {warning}");
    }
    let source = Source::new(&args.scene, &defines, options).map_err(|e| e.to_string())?;
    Ok((loaded.scene, source))
}

/// Solve `scene`, loaded from `args`, or resume the solve in the solution
/// or checkpoint file `resume`; a gathering solve saves checkpoints
/// through `saver`.
fn solve_loaded(
    args: &SolveArgs,
    scene: &Scene,
    resume: Option<&Path>,
    saver: Option<&Saver>,
    progress: &Reporter,
) -> Result<Solution, String> {
    let in_scene = |e: wavrad_core::Error| format!("{}: {e}", args.scene.display());
    if let Some(resume) = resume {
        if args.solver == Some(Solver::Shoot) || args.progressive.is_some() {
            return Err("--resume resumes a gathering solve; --solver shoot and \
                        --progressive do not go with it"
                .into());
        }
        progress.note(&format!("reading {}", resume.display()));
        let read = read_unfinished(resume).map_err(|e| e.to_string())?;
        for warning in &read.warnings {
            eprintln!("wavrad: warning: {warning}");
        }
        let settings = (read.settings)
            .for_resuming(&args.settings.values)
            .map_err(in_scene)?;
        return wavrad_core::solve::resume(scene, &settings, read.unfinished(), saver, progress)
            .map_err(|e| format!("{}: {e}", resume.display()));
    }
    let settings = SolveSettings::from_values(&args.settings.values)
        .map_err(|e| format!("{}: {e}", args.scene.display()))?;
    match (args.solver.unwrap_or_default(), &args.progressive) {
        (Solver::Gather, None) => solve_saving(scene, &settings, saver, progress).map_err(in_scene),
        (Solver::Gather, Some(_)) => Err("--progressive needs --solver shoot".into()),
        (Solver::Shoot, None) => solve_shooting(scene, &settings, progress, None).map_err(in_scene),
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
            let solution =
                solve_shooting(scene, &settings, progress, Some(&mut on_step)).map_err(in_scene)?;
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
    let image = Renderer::new(solution)
        .preview()
        .map_err(|e| e.to_string())?;
    let path = dir.join(format!("step-{:04}.exr", step.index));
    wavrad_io::write_image(&path, image.width, image.height, &image.rgb).map_err(|e| e.to_string())
}

/// Fail before any work where an output (an image or a solution file)
/// could not be written: either file's directory, or statistics that would
/// overwrite the output.
fn check_outputs(output: Option<&Path>, stats: Option<&Path>) -> Result<(), String> {
    for path in output.iter().chain(stats.iter()) {
        wavrad_io::check_writable(path).map_err(|e| e.to_string())?;
    }
    if let (Some(output), Some(stats)) = (output, stats) {
        let canonical = |p: &Path| {
            let dir = match p.parent() {
                Some(d) if !d.as_os_str().is_empty() => d,
                _ => Path::new("."),
            };
            dir.canonicalize()
                .ok()
                .map(|d| d.join(p.file_name().unwrap_or_default()))
        };
        if canonical(output) == canonical(stats) {
            return Err(format!(
                "{}: --stats and --output name the same file",
                stats.display()
            ));
        }
    }
    Ok(())
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

fn report(solution: &Solution, output: Option<&Path>, progress: &Reporter) {
    let s = &solution.stats;
    let t = &s.times;
    if let Some(warning) = s.cut_short_warning() {
        eprintln!("wavrad: warning: {warning}");
    }
    if progress.show == Show::Nothing {
        return report_warnings(solution);
    }
    // A bounce limit stops the sweeps where it says, not at a residual.
    let ended = match wavrad_core::solve::bounces(&solution.scene) {
        Some(limit) => format!("the scene's bounce limit {limit}"),
        None => format!("residual {:.2e}", s.residual),
    };
    eprintln!(
        "wavrad: {} surfaces, {} two-point nodes, {} two-point interactions; {} iterations ({ended}); \
         kernels {:.2}s, solve {:.2}s, render {:.2}s",
        s.surfaces,
        s.two_point_nodes,
        s.two_point_interactions,
        s.iterations,
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
    report_warnings(solution);
    if let Some(out) = output {
        eprintln!("wavrad: wrote {}", out.display());
    }
}

/// Warnings about a solve that ended without a hard failure.
fn report_warnings(solution: &Solution) {
    let tolerance = solution.settings.tolerance;
    if let Some(message) = solution.stats.not_converged_warning(tolerance) {
        eprintln!("wavrad: warning: {message}; more --max-iterations may help");
    }
}

/// The solve's statistics as JSON to `--stats`, with the scene file and,
/// after a render, the render's settings by their described names.
fn write_stats(
    args: &SolveArgs,
    solution: &Solution,
    render: Option<&RenderSettings>,
) -> Result<(), String> {
    let Some(path) = &args.stats else {
        return Ok(());
    };
    let mut json = serde_json::to_value(&solution.stats).map_err(|e| e.to_string())?;
    json["scene"] = serde_json::Value::String(args.scene.display().to_string());
    if let Some(settings) = render {
        let values: std::collections::BTreeMap<_, _> = settings.values().into_iter().collect();
        json["render"] = serde_json::to_value(values).map_err(|e| e.to_string())?;
    }
    let text = serde_json::to_string_pretty(&json).map_err(|e| e.to_string())?;
    wavrad_io::write_atomic(path, text.as_bytes()).map_err(|e| e.to_string())
}
