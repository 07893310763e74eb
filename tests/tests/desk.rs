//! A person seated at a desk, seen from the chest up with the table before them: the
//! pose stage reports the pelvis and legs not visible, and the gesture stage must still
//! follow the drawing hand (it once dropped every frame whose pelvis was unseen, and
//! found nothing at a desk).

use airglyph_system_tests::{one_at_a_time, played_gestures, succeed, Isolated};

#[test]
fn symbols_drawn_at_a_desk_are_found_through_all_three_stages() {
    let _one = one_at_a_time();
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let rec = tmp.path().join("desk");
    succeed(
        p.command("airglyph")
            .args(["synth", "--motion", "draw:2468", "--seated", "--table"])
            .args([
                "--framing",
                "upper-body",
                "--distance",
                "1.4",
                "--seed",
                "3",
            ])
            .args(["--resolution", "320x240", "--out"])
            .arg(&rec),
    );
    let found = played_gestures(&p, &[], &rec);
    println!("{found:?}");
    let labels: Vec<&str> = found.iter().filter_map(|e| e["label"].as_str()).collect();
    let right = ["2", "4", "6", "8"]
        .iter()
        .filter(|s| labels.contains(s))
        .count();
    assert!(right >= 2, "{right} of 4 found: {labels:?}");
}
