//! `hom` — visibility culling for large 3D scenes, from the command line.
//!
//! The subcommand names and flags are a contract that scripts depend on.

#![forbid(unsafe_code)]

mod args;
mod commands;
mod setup;
mod table;

use args::{Cli, Command, OccludersCommand, PvsCommand, SceneCommand};
use clap::{CommandFactory, FromArgMatches};

/// Output cut short by its reader (`hom scenes | head -1`) is not an error:
/// `println!` panics when the pipe is closed, so that one panic ends the
/// process quietly and successfully, as other command-line tools do.
fn quiet_when_the_reader_leaves() {
    let report = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let message = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or("");
        if message.contains("failed printing to stdout") && message.contains("Broken pipe") {
            std::process::exit(0);
        }
        report(info);
    }));
}

fn main() {
    quiet_when_the_reader_leaves();
    let matches = Cli::command().get_matches();
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    let result = match cli.command {
        Command::Demo(a) => commands::demo::run(a),
        Command::Walk(a) => commands::walk::run(a),
        Command::View(a) => commands::view::run(a),
        Command::Render(a) => commands::render::run(a),
        Command::Bench(a) => {
            commands::bench::run(a, matches.subcommand_matches("bench").expect("parsed a bench command"))
        }
        Command::Scenes => commands::scene::list(),
        Command::Scene { command } => match command {
            SceneCommand::Info { scene, clusters } => commands::scene::info(&scene, clusters),
            SceneCommand::Export { scene, out, clusters } => commands::scene::export(&scene, &out, clusters),
        },
        Command::Occluders { command } => match command {
            OccludersCommand::Info {
                scene,
                side,
                summary,
                pictures,
                walk_frames,
            } => commands::occluders::info(&scene, side, summary, pictures.as_deref(), walk_frames),
            OccludersCommand::Export { scene, out } => commands::occluders::export(&scene, &out),
        },
        Command::Pvs { command } => match command {
            PvsCommand::Bake(a) => commands::pvs::bake(a),
            PvsCommand::Merge { out, shards } => commands::pvs::merge(&out, &shards),
            PvsCommand::Info { file, picture, scene } => {
                commands::pvs::info(&file, picture.as_deref(), scene.as_deref())
            }
            PvsCommand::Check(a) => commands::pvs::check(a),
        },
    };
    if let Err(e) = result {
        // One line naming the problem; no backtrace.
        eprintln!("error: {e:#}");
        std::process::exit(2);
    }
}
