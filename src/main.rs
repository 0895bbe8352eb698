//! The `softgrain` command: parse arguments, call the library, map errors to exit codes
//! (0 success, 2 wrong input, 1 a run that failed).

use clap::{Parser, Subcommand};
use softgrain::config;
use softgrain::pipeline::{self, RunError, RunOptions, Stage};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "softgrain",
    version,
    about = "Soft granular materials: bonded particles and implicit MPM"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run or inspect a pipeline.
    Pipeline {
        #[command(subcommand)]
        action: PipelineAction,
    },
    /// Check a pipeline file and print it with every default filled in.
    Validate {
        file: PathBuf,
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
    },
    /// Work-precision sweep of the engines (pipelines/bench.yaml): CSV and plots.
    Bench {
        file: PathBuf,
        #[arg(long, default_value = "runs")]
        out: PathBuf,
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Run only the setting of this index and print its outcome as JSON (the child
        /// process that measures one setting's memory).
        #[arg(long, hide = true)]
        one: Option<usize>,
    },
}

#[derive(Subcommand)]
enum PipelineAction {
    /// Run every stage whose checkpoint is missing.
    Run {
        file: PathBuf,
        #[arg(long, default_value = "runs")]
        out: PathBuf,
        /// Override a value by its dotted path, e.g. --set prepare.grains=50.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Recompute this stage and everything after it.
        #[arg(long, value_parser = parse_stage)]
        from: Option<Stage>,
        /// Stop after this stage.
        #[arg(long, value_parser = parse_stage)]
        until: Option<Stage>,
        /// Worker threads (default: all cores).
        #[arg(long)]
        jobs: Option<usize>,
        /// No progress bars or per-stage lines.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Print cached / stale / missing for every stage and case; computes nothing.
    Status {
        file: PathBuf,
        #[arg(long, default_value = "runs")]
        out: PathBuf,
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
    },
}

fn parse_stage(s: &str) -> Result<Stage, String> {
    Stage::parse(s)
        .ok_or_else(|| format!("unknown stage `{s}` (prepare, discretise, compact, analyse)"))
}

/// A write past `ulimit -f` raises SIGXFSZ, which kills the process before any message;
/// ignored, the write fails with EFBIG instead and the run reports it like a full disk
/// (exit 1, finished checkpoints kept).
#[cfg(target_os = "linux")]
fn ignore_file_size_signal() {
    const SIGXFSZ: i32 = 25;
    const SIG_IGN: usize = 1;
    unsafe extern "C" {
        fn signal(signum: i32, handler: usize) -> usize;
    }
    // SAFETY: installs the "ignore" disposition for one signal; no Rust handler runs.
    unsafe {
        signal(SIGXFSZ, SIG_IGN);
    }
}

#[cfg(not(target_os = "linux"))]
fn ignore_file_size_signal() {}

fn main() -> ExitCode {
    ignore_file_size_signal();
    let cli = Cli::parse();
    // a misspelt measuring switch must not silently measure the default path
    if let Err(e) = softgrain::shortcuts::Shortcuts::from_env() {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    match cli.command {
        Command::Validate { file, set } => match config::load(&file, &set) {
            Ok(loaded) => {
                println!("{}: valid", file.display());
                match serde_saphyr::to_string(&loaded.pipeline) {
                    Ok(text) => print!("{text}"),
                    Err(e) => eprintln!("cannot print the pipeline: {e}"),
                }
                ExitCode::SUCCESS
            }
            Err(e) => input_error(&e),
        },
        Command::Bench {
            file,
            out,
            set,
            one,
        } => bench(&file, &out, &set, one),
        Command::Pipeline { action } => match action {
            PipelineAction::Status { file, out, set } => match config::load(&file, &set) {
                Ok(loaded) => {
                    if let Some(pid) = pipeline::running(&loaded, &out) {
                        println!("a run (pid {pid}) is writing to this folder now");
                    }
                    for (node, word) in pipeline::status(&loaded, &out) {
                        println!(
                            "{:<10} {:<36} {}  {word}",
                            node.stage.name(),
                            node.case,
                            node.short()
                        );
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => input_error(&e),
            },
            PipelineAction::Run {
                file,
                out,
                set,
                from,
                until,
                jobs,
                quiet,
            } => {
                // The whole run executes on the pool's threads, so a parallel loop is
                // joined by a worker instead of handed over from the main thread and
                // waited for. With one worker and the other core busy, that hand-over took
                // 40% of a 100-grain BPM relaxation's wall time (README "Performance").
                let pool = match rayon::ThreadPoolBuilder::new()
                    .num_threads(jobs.unwrap_or(0))
                    .build()
                {
                    Ok(pool) => pool,
                    Err(e) => {
                        eprintln!("--jobs {}: {e}", jobs.unwrap_or(0));
                        return ExitCode::from(2);
                    }
                };
                let loaded = match config::load(&file, &set) {
                    Ok(l) => l,
                    Err(e) => return input_error(&e),
                };
                let opts = RunOptions {
                    out,
                    from,
                    until,
                    quiet,
                };
                // Ctrl-C, SIGTERM, SIGHUP: a long stage saves a snapshot and stops at its next step.
                if let Err(e) = ctrlc::set_handler(|| {
                    pipeline::INTERRUPT.store(true, std::sync::atomic::Ordering::Relaxed);
                }) {
                    eprintln!("warning: Ctrl-C and SIGTERM will not save a snapshot: {e}");
                }
                match pool.install(|| pipeline::run(&loaded, &opts)) {
                    Ok(_) => ExitCode::SUCCESS,
                    Err(RunError::Input(e)) => input_error(&e),
                    Err(e) => {
                        eprintln!("error: {e}");
                        ExitCode::from(1)
                    }
                }
            }
        },
    }
}

fn bench(
    file: &std::path::Path,
    out: &std::path::Path,
    set: &[String],
    one: Option<usize>,
) -> ExitCode {
    let spec = match softgrain::bench::load(file, set) {
        Ok(s) => s,
        Err(e) => return input_error(&e),
    };
    let result = match one {
        Some(index) => softgrain::bench::run_one(&spec, index).and_then(|o| {
            serde_json::to_string(&o)
                .map(|line| println!("{line}"))
                .map_err(|e| e.to_string())
        }),
        None => std::env::current_exe()
            .map_err(|e| format!("cannot find this program to run the settings: {e}"))
            .and_then(|exe| softgrain::bench::run(&spec, file, set, out, &exe))
            .map(|dir| println!("wrote {}", dir.display())),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: bench: {e}");
            ExitCode::from(1)
        }
    }
}

fn input_error(e: &config::InputError) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::from(2)
}
