//! `hom` — visibility culling for large 3D scenes, from the command line.
//!
//! The subcommand names and flags are a contract that scripts depend on.

#![forbid(unsafe_code)]

mod args;
mod commands;
mod setup;
mod table;

use args::{Cli, Command, OccludersCommand, PvsCommand, SceneCommand};
use clap::Parser;

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Demo(a) => commands::demo::run(a),
        Command::Walk(a) => commands::walk::run(a),
        Command::Render(a) => commands::render::run(a),
        Command::Bench(a) => commands::bench::run(a),
        Command::Scenes => commands::scene::list(),
        Command::Scene { command } => match command {
            SceneCommand::Info { scene } => commands::scene::info(&scene),
            SceneCommand::Export { scene, out } => commands::scene::export(&scene, &out),
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
