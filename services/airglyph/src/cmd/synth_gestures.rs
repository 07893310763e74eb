//! `airglyph synth-gestures`: the 3-D vocabulary (`airglyph_synth::shapes3d`) drawn by
//! synthetic people, as trajectory JSONL with 3-D points: a development set for
//! gestures in three dimensions, split by person (each person is a `subject`), that
//! needs no camera. Sets made with different seeds have different people, so a setting
//! can be chosen on one seed's and reported on another's.

use airglyph_gesture::lab::Sample;
use airglyph_ipc::options;
use anyhow::Context;
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args, Clone)]
pub struct Args {
    /// Where to write the trajectory JSONL.
    #[arg(long)]
    pub out: PathBuf,
    /// People, each with their own size, depth, plane, stretch, speed, timing and noise.
    #[arg(long, default_value_t = 10, value_parser = options::within(1usize, 10_000), allow_negative_numbers = true)]
    pub persons: usize,
    /// Times each person draws every gesture.
    #[arg(long, default_value_t = 6, value_parser = options::within(1usize, 1000), allow_negative_numbers = true)]
    pub repetitions: usize,
    /// Everything follows from it; the people are named after it (`s{SEED}-p{K}`).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write the same samples without their depth (as a 2-D camera would see them).
    #[arg(long)]
    pub flat: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let drawn = airglyph_synth::air3d::draw_vocabulary(args.persons, args.repetitions, args.seed);
    let mut text = String::new();
    for g in &drawn {
        let sample = Sample {
            label: g.label.clone(),
            subject: g.person.clone(),
            strokes: vec![g.points.iter().map(|p| [p[0], p[1]]).collect()],
            depth: (!args.flat).then(|| vec![g.points.iter().map(|p| p[2]).collect()]),
        };
        text.push_str(&sample.to_jsonl());
        text.push('\n');
    }
    airglyph_core::file::write_whole(&args.out, text)
        .with_context(|| format!("{}: cannot write", args.out.display()))?;
    let _ = writeln!(
        std::io::stderr(),
        "{} gestures ({} of the vocabulary by {} people, {} repetitions each{}) written to {}",
        drawn.len(),
        airglyph_synth::shapes3d::VOCABULARY.len(),
        args.persons,
        args.repetitions,
        if args.flat { ", depth dropped" } else { "" },
        args.out.display()
    );
    Ok(())
}
