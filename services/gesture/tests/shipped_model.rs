//! The shipped model reads the synthetic person's handwriting: every built-in glyph of
//! airglyph-synth (what `airglyph demo` draws), classified alone, is named as itself.
//! A glyph drawn in an order no writer of the training data uses fails here, not in a
//! 3-minute demo (the "4" once went up its stem first and was read as a "C").

use airglyph_gesture::{ModelSource, Trajectory};
use airglyph_synth::glyphs::{template, BUILT_IN};

#[test]
fn every_built_in_glyph_is_read_as_itself_by_the_shipped_model() {
    let model = ModelSource::Shipped
        .load()
        .expect("the shipped model loads");
    let mut wrong = Vec::new();
    for c in BUILT_IN.chars() {
        let glyph = template(c).expect("a built-in glyph");
        let strokes: Vec<Vec<[f32; 2]>> = glyph
            .strokes
            .iter()
            .map(|s| s.iter().map(|p| [p.x, p.y]).collect())
            .collect();
        let got = model.classify(&Trajectory::from_strokes(&strokes));
        let label = &model.labels[got.class];
        if label != &c.to_string() {
            wrong.push(format!("{c} read as {label} ({:.2})", got.score));
        }
    }
    assert!(wrong.is_empty(), "{wrong:?}");
}
