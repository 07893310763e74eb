//! What a camera on a desk, a screen or a robot sees: a person close, seen from the
//! waist up, seated behind a table, arms at rest, through the sensor model. Each frame
//! is estimated afresh (no history), as a single real frame is: never a panic or NaN,
//! the legs reported out of view when the image or the table hides them, nothing
//! reported visible outside the image, and the upper body where the person is.

use airglyph_core::{Intrinsics, Joint, Skeleton};
use airglyph_pose::{PoseConfig, PoseEstimator, PoseResult};
use airglyph_synth::{
    Background, BodySpec, Chair, MotionSpec, Placement, Posture, Prop, SceneConfig, ScriptedPose,
    Synthesizer, Table,
};

fn qvga() -> Intrinsics {
    Intrinsics::default().scaled_to(320, 240)
}

/// `pose` held `distance_m` from the camera in a furnished room, with the sensor model.
fn at(distance_m: f32, pose: ScriptedPose) -> SceneConfig {
    SceneConfig {
        intrinsics: qvga(),
        motion: MotionSpec::Pose(pose),
        background: Background::Room,
        sensor_noise: true,
        placement: Placement {
            distance_m,
            ..Placement::default()
        },
        ..SceneConfig::default()
    }
}

fn seated(cfg: SceneConfig, table: bool) -> SceneConfig {
    let chair = Chair::default();
    let mut props = vec![Prop::Chair(chair)];
    if table {
        props.push(Prop::Table(Table::default()));
    }
    SceneConfig {
        posture: Posture::Seated {
            seat_height_m: chair.seat_height_m,
        },
        props,
        ..cfg
    }
}

fn upper_body(cfg: SceneConfig) -> SceneConfig {
    cfg.framing_upper_body().expect("the body loads")
}

/// The MakeHuman body of `shape` (MakeHuman's sliders, "" the default), or None, saying
/// the test is skipped, when the body is not fetched.
fn makehuman(shape: &str) -> Option<BodySpec> {
    let shape = if shape.is_empty() {
        Default::default()
    } else {
        airglyph_synth::MakeHumanShape::parse(shape).expect("a shape")
    };
    let body = BodySpec::MakeHuman {
        assets: None,
        shape,
    };
    if body.load().is_err() {
        eprintln!("skipped: the MakeHuman body is not fetched (scripts/fetch-assets)");
        return None;
    }
    Some(body)
}

/// Frame `frame` of the scene, estimated with no history.
fn single(cfg: SceneConfig, frame: usize) -> (PoseResult, airglyph_synth::FrameTruth) {
    let k = cfg.intrinsics;
    let (img, truth) = Synthesizer::new(cfg).expect("scene").render(frame);
    let r = PoseEstimator::new(k, PoseConfig::default()).estimate(img.view());
    assert!(r.skeleton.is_finite(), "{r:?}");
    assert!(r
        .skeleton
        .confidence
        .iter()
        .all(|c| (0.0..=1.0).contains(c)));
    (r, truth)
}

/// Every joint reported visible projects inside the image, and has a confidence;
/// every joint not visible has none.
fn visibility_is_consistent(r: &PoseResult, k: &Intrinsics) {
    for j in Joint::ALL {
        let s = &r.skeleton;
        if s.visible[j.index()] {
            let (u, v) = k.project(&s[j]).expect("in front of the camera");
            assert!(
                (0.0..k.width as f32).contains(&u) && (0.0..k.height as f32).contains(&v),
                "{j:?} reported visible at ({u:.0}, {v:.0}), outside the image"
            );
        } else {
            assert_eq!(s.confidence[j.index()], 0.0, "{j:?} not visible");
        }
    }
}

fn error_m(r: &Skeleton, truth: &Skeleton, j: Joint) -> f32 {
    (r[j] - truth[j]).norm()
}

const ARMS: [Joint; 4] = [
    Joint::LeftElbow,
    Joint::RightElbow,
    Joint::LeftHand,
    Joint::RightHand,
];

const LEGS: [Joint; 4] = [
    Joint::LeftKnee,
    Joint::RightKnee,
    Joint::LeftFoot,
    Joint::RightFoot,
];

#[test]
fn seen_from_the_waist_up_at_any_distance_the_legs_are_out_of_view() {
    // (At 1.6 m and more the framing puts the knees at the image's lower edge, where a
    // knee estimated a few pixels inside it is in view.)
    for (distance_m, pose) in [
        (0.8, ScriptedPose::ArmsAtSides),
        (1.0, ScriptedPose::Wave),
        (1.2, ScriptedPose::Neutral),
        (1.2, ScriptedPose::HandsInFront),
    ] {
        let k = qvga();
        let (r, truth) = single(upper_body(at(distance_m, pose)), 0);
        assert!(r.person_found, "{distance_m} m, {pose:?}");
        visibility_is_consistent(&r, &k);
        for j in LEGS {
            assert!(!truth.skeleton.visible[j.index()], "the scene hides {j:?}");
            assert!(
                !r.skeleton.visible[j.index()],
                "{distance_m} m, {pose:?}: {j:?} reported visible"
            );
        }
        for j in [Joint::LeftShoulder, Joint::RightShoulder] {
            let e = error_m(&r.skeleton, &truth.skeleton, j);
            assert!(r.skeleton.visible[j.index()], "{j:?} in view");
            assert!(e < 0.12, "{distance_m} m, {pose:?}: {j:?} off by {e:.2} m");
        }
    }
}

#[test]
fn from_the_waist_up_the_torso_is_held_at_the_persons_own_neck() {
    // Cut at the waist, the torso slides along its axis; the template's head and
    // shoulders then hold it 10–15 cm high on this body, whose neck is longer than
    // the template's. The neck's base in the outline holds it at the person's own.
    for pose in [ScriptedPose::Neutral, ScriptedPose::ArmsAtSides] {
        let (r, truth) = single(upper_body(at(1.2, pose)), 0);
        assert!(r.person_found, "{pose:?}");
        let e = error_m(&r.skeleton, &truth.skeleton, Joint::Neck);
        assert!(e < 0.09, "{pose:?}: the neck off by {e:.2} m");
        for j in [Joint::LeftShoulder, Joint::RightShoulder] {
            let e = error_m(&r.skeleton, &truth.skeleton, j);
            assert!(e < 0.045, "{pose:?}: {j:?} off by {e:.2} m");
        }
    }
}

#[test]
fn arms_at_rest_are_found_in_a_single_frame_near_and_far() {
    // (Not yet, the pose README's "Where it fails": arms at the sides at 1.0 m, where
    // the procedural body's hanging arms merge with its torso, and at 3.8 m; hands on
    // the thighs at 1.4 m, from the waist up, where the hands come 20 cm short: the
    // procedural body's arm, shoulder to palm, is 0.64 m against the default
    // template's 0.50, which a single frame cannot learn when the arms show no end of
    // their own, so even started from the truth the fit ends 14 cm off on average.)
    for (distance_m, pose) in [
        (2.0, ScriptedPose::ArmsAtSides),
        (2.5, ScriptedPose::ArmsAtSides),
    ] {
        let k = qvga();
        let (r, truth) = single(at(distance_m, pose), 0);
        assert!(r.person_found, "{distance_m} m, {pose:?}");
        visibility_is_consistent(&r, &k);
        for j in ARMS {
            let e = error_m(&r.skeleton, &truth.skeleton, j);
            assert!(e < 0.2, "{distance_m} m, {pose:?}: {j:?} off by {e:.2} m");
        }
    }
}

#[test]
fn seated_behind_a_table_the_legs_under_it_are_not_invented() {
    // (Not yet, the pose README's "Where it fails": hands in the lap at 1.2 m with no
    // table, where the thighs, out of view towards the camera, are fitted bent back
    // into the chair, a knee in the image behind the hips; waving at 1.6 m behind the
    // table, where the torso is fitted 20 cm high, its hips above the table top, and a
    // leg up before it. Both passed while a NaN in the joint priors froze the legs at
    // their start.)
    for (distance_m, pose, table) in [
        (1.4, ScriptedPose::ArmsCrossed, true),
        (1.4, ScriptedPose::HandsOnTable, true),
    ] {
        let k = qvga();
        let (r, truth) = single(upper_body(seated(at(distance_m, pose), table)), 0);
        assert!(r.person_found, "{distance_m} m, {pose:?}");
        visibility_is_consistent(&r, &k);
        for j in Joint::ALL {
            if !truth.skeleton.visible[j.index()] && LEGS.contains(&j) {
                assert!(
                    !r.skeleton.visible[j.index()],
                    "{distance_m} m, {pose:?}: {j:?} is hidden but reported visible"
                );
            }
        }
        for j in [Joint::LeftShoulder, Joint::RightShoulder] {
            let e = error_m(&r.skeleton, &truth.skeleton, j);
            assert!(e < 0.12, "{distance_m} m, {pose:?}: {j:?} off by {e:.2} m");
        }
    }
}

#[test]
fn hands_resting_on_a_table_are_no_feet() {
    // At 640×480, as a Kinect delivers: the forearms lie on the table top, their hands
    // as low in the image as feet would be, the legs hidden under the table. Without
    // the sensor model too: with it, its shadows happen to cut the forearms' paths.
    for noise in [false, true] {
        let cfg = SceneConfig {
            intrinsics: Intrinsics::default(),
            sensor_noise: noise,
            ..at(1.4, ScriptedPose::HandsOnTable)
        };
        let k = cfg.intrinsics;
        let (r, truth) = single(upper_body(seated(cfg, true)), 0);
        assert!(r.person_found);
        visibility_is_consistent(&r, &k);
        for j in LEGS {
            assert!(!truth.skeleton.visible[j.index()], "the table hides {j:?}");
            assert!(!r.skeleton.visible[j.index()], "{j:?} reported visible");
        }
        for foot in [Joint::LeftFoot, Joint::RightFoot] {
            for hand in [Joint::LeftHand, Joint::RightHand] {
                let d = (r.skeleton[foot] - truth.skeleton[hand]).norm();
                assert!(d > 0.2, "{foot:?} on the {hand:?}, {d:.2} m from it");
            }
        }
    }
}

#[test]
fn seated_with_no_table_the_legs_below_the_image_are_not_invented() {
    // Seated close, framed from the waist up: at 1.0 m the hips are below the image's
    // edge and the legs show nothing of their own; at 1.2 m the thighs run out of the
    // image towards the camera, cut by its edge before the feet.
    for (distance_m, pose, hidden) in [
        (1.0, ScriptedPose::Neutral, &LEGS[..]),
        (1.0, ScriptedPose::ArmsAtSides, &LEGS[..]),
        (1.0, ScriptedPose::HandsInLap, &LEGS[..]),
        (1.2, ScriptedPose::Neutral, &LEGS[2..]),
        (1.2, ScriptedPose::HandsOnThighs, &LEGS[2..]),
    ] {
        let k = qvga();
        let (r, truth) = single(upper_body(seated(at(distance_m, pose), false)), 0);
        assert!(r.person_found, "{distance_m} m, {pose:?}");
        visibility_is_consistent(&r, &k);
        for j in hidden {
            assert!(!truth.skeleton.visible[j.index()], "the scene hides {j:?}");
            assert!(
                !r.skeleton.visible[j.index()],
                "{distance_m} m, {pose:?}: {j:?} reported visible"
            );
        }
    }
}

#[test]
fn seated_hanging_arms_are_not_pulled_into_the_chairs_back() {
    // The chair's back shows between a seated person's hanging arms and torso, taken
    // into the person's mask across its depth jumps; explaining it, the fit swung the
    // forearms back into it (hands 35 cm off at 1.0 m, 37 cm at 1.2 m with the sensor).
    // On the MakeHuman body: the procedural body's arms are longer than the template's,
    // which a single frame of hanging arms cannot learn (above). (Not yet: without the
    // sensor model at 1.2 and 1.4 m the fit's starts do not reach the hanging arms,
    // hands 22–31 cm off; pose NOTES, 2026-12-05, morning.)
    let Some(body) = makehuman("") else {
        return;
    };
    for (distance_m, noise) in [(1.0, false), (1.0, true), (1.2, true), (1.4, true)] {
        let mut cfg = seated(at(distance_m, ScriptedPose::ArmsAtSides), false);
        cfg.body = body.clone();
        cfg.sensor_noise = noise;
        let (r, truth) = single(upper_body(cfg), 0);
        assert!(r.person_found, "{distance_m} m");
        visibility_is_consistent(&r, &qvga());
        for j in ARMS {
            let e = error_m(&r.skeleton, &truth.skeleton, j);
            assert!(
                e < 0.1,
                "{distance_m} m, noise {noise}: {j:?} off by {e:.2} m"
            );
        }
    }
}

#[test]
fn forearms_resting_on_a_table_do_not_make_the_table_the_person() {
    // Seen from the face's height, a table's top just below the camera holds half the
    // lower image without filling its bottom (its front edge and the floor do), and
    // was taken for no floor: the forearms resting on it joined the whole table to a
    // person smaller than it, and the skeleton was fitted to the table (shoulders 0.5–
    // 1 m off). (Not yet: the sixteen-year-old through the sensor model, the camera
    // 15 cm above the table's top, whose body is fitted upside down; pose NOTES.)
    for (shape, distance_m, noise) in [
        ("gender=0", 1.5, false),
        ("gender=0", 1.5, true),
        ("age=0.3", 1.4, false),
    ] {
        let Some(body) = makehuman(shape) else {
            return;
        };
        let mut cfg = seated(at(distance_m, ScriptedPose::HandsOnTable), true);
        cfg.body = body;
        cfg.sensor_noise = noise;
        let (r, truth) = single(upper_body(cfg), 0);
        assert!(r.person_found, "{shape}, noise {noise}");
        for j in [
            Joint::Head,
            Joint::Neck,
            Joint::LeftShoulder,
            Joint::RightShoulder,
        ] {
            let e = error_m(&r.skeleton, &truth.skeleton, j);
            assert!(e < 0.1, "{shape}, noise {noise}: {j:?} off by {e:.2} m");
        }
    }
}

/// The MakeHuman body seated at a desk drawing A–J, from the waist up, without the
/// sensor model; None when the body is not fetched.
fn drawing_at_a_desk(distance_m: f32) -> Option<SceneConfig> {
    let body = makehuman("")?;
    let mut cfg = seated(at(distance_m, ScriptedPose::Neutral), true);
    cfg.body = body;
    cfg.motion = MotionSpec::parse("draw:ABCDEFGHIJ", None, false).expect("a drawing");
    cfg.sensor_noise = false;
    Some(upper_body(cfg))
}

#[test]
fn a_corner_of_the_room_as_large_as_a_seated_person_is_not_taken_for_them() {
    // With the drawing hand raised to the image's top edge, the walls' corner beside a
    // person seated at a desk was twice the person's pixels and, lying behind what
    // borders it, still took the person's place: the skeleton 2 m off, on the wall.
    let Some(cfg) = drawing_at_a_desk(1.4) else {
        return;
    };
    let (r, truth) = single(cfg, 54);
    assert!(r.person_found);
    for j in [Joint::Neck, Joint::LeftShoulder, Joint::RightShoulder] {
        let e = error_m(&r.skeleton, &truth.skeleton, j);
        assert!(e < 0.15, "{j:?} off by {e:.2} m");
    }
}

#[test]
fn at_a_desk_with_the_forearms_on_it_a_single_frame_faces_the_camera() {
    // The torso region of a person at a desk, forearms on it, is flattest across the
    // body rather than along the camera's ray: its PCA turned the torso 80–90° and the
    // arms with it (a hand 65 cm off, an elbow 29 cm).
    let Some(cfg) = drawing_at_a_desk(1.4) else {
        return;
    };
    let (r, truth) = single(cfg, 90);
    for j in [Joint::LeftShoulder, Joint::RightShoulder]
        .into_iter()
        .chain(ARMS)
    {
        let e = error_m(&r.skeleton, &truth.skeleton, j);
        assert!(e < 0.1, "{j:?} off by {e:.2} m");
    }
}

#[test]
fn a_chair_back_wider_than_the_person_leaning_on_it_is_no_part_of_them() {
    // A short woman leaning on a chair's back wider than her: back and chair meet with
    // no depth jump, the chair is one part with her, and the fit took it for arms (an
    // elbow and a hand 39 cm off, up the chair's back, at 1.0 m with the sensor).
    let Some(body) = makehuman("gender=0,age=0.85,height=0.3,weight=0.7") else {
        return;
    };
    let mut cfg = seated(at(1.0, ScriptedPose::ArmsAtSides), false);
    cfg.body = body;
    let (r, truth) = single(upper_body(cfg), 0);
    assert!(r.person_found);
    visibility_is_consistent(&r, &qvga());
    for j in ARMS {
        let e = error_m(&r.skeleton, &truth.skeleton, j);
        assert!(e < 0.1, "{j:?} off by {e:.2} m");
    }
}

#[test]
fn a_leg_whose_hip_is_behind_the_table_shows_no_knee_or_foot() {
    // A tall, broad person at a desk drawing, 1.6 m away, whose first frame the fit
    // took with the legs folded back behind the chair: the hips, behind the table, were
    // reported hidden, but the feet, 70 cm behind the body where the wall shows past it,
    // were reported visible.
    let mut cfg = seated(at(1.6, ScriptedPose::Neutral), true);
    cfg.body = BodySpec::Procedural(airglyph_synth::ProceduralBody {
        height_m: 1.92,
        build: 1.25,
    });
    cfg.intrinsics = Intrinsics::default();
    cfg.sensor_noise = false;
    cfg.seed = 12;
    cfg.motion = MotionSpec::parse("draw:UVWXYZ2468", None, false).expect("a drawing");
    let cfg = upper_body(cfg);
    let k = cfg.intrinsics;
    let (r, truth) = single(cfg, 0);
    assert!(r.person_found);
    visibility_is_consistent(&r, &k);
    for j in LEGS {
        assert!(!truth.skeleton.visible[j.index()], "{j:?} is in view");
        assert!(
            !r.skeleton.visible[j.index()],
            "{j:?} is hidden but reported visible"
        );
    }
}

/// `frames` tracked frames of `cfg`: of those with a leg's joint out of view, how many
/// report one such joint visible, and how many there are.
fn hidden_legs_shown(cfg: SceneConfig, frames: usize) -> (usize, usize) {
    let k = cfg.intrinsics;
    let mut synth = Synthesizer::new(cfg).expect("scene");
    let mut est = PoseEstimator::new(k, PoseConfig::default());
    let (mut shown, mut hidden_frames) = (0, 0);
    for i in 0..frames {
        let (img, truth) = synth.render(i);
        let r = est.estimate(img.view());
        visibility_is_consistent(&r, &k);
        let hidden: Vec<Joint> = LEGS
            .into_iter()
            .filter(|j| !truth.skeleton.visible[j.index()])
            .collect();
        if !hidden.is_empty() {
            hidden_frames += 1;
            shown += usize::from(hidden.iter().any(|j| r.skeleton.visible[j.index()]));
        }
    }
    (shown, hidden_frames)
}

#[test]
fn seated_at_rest_the_legs_out_of_view_are_not_reported() {
    // An older short woman seated at rest, 1.1 m, tracked: a leg's end found near the
    // hip (a hand hanging beside it, a seated knee, the chair's side behind her back),
    // and the foot fitted beside it reported visible though the image shows nothing
    // below her thighs.
    let Some(body) = makehuman("gender=0,age=0.85,height=0.3,weight=0.7") else {
        return;
    };
    let mut cfg = seated(at(1.1, ScriptedPose::Neutral), false);
    cfg.body = body;
    cfg.motion = MotionSpec::Rest;
    cfg.intrinsics = Intrinsics::default();
    cfg.sensor_noise = false;
    cfg.seed = 24;
    let cfg = upper_body(cfg);
    let (shown, frames) = hidden_legs_shown(cfg, 130);
    assert!(frames > 100, "{frames} frames with the legs out of view");
    // The bar: hidden lower joints reported so in 99 % of such frames. (32
    // of 130 frames failed before the rules for a leg's end near the hip; 16 before
    // the feet the camera sees through, the chair's maxima and the image's last
    // pixels.)
    assert!(
        shown * 100 <= frames,
        "{shown} of {frames} frames show a hidden knee or foot"
    );
}

#[test]
fn seated_at_rest_a_hand_in_the_lap_is_no_leg_end() {
    // MakeHuman seated at rest, 1.2 m, tracked, on a draw where a hand in the lap is
    // taken for a leg's end near the hip, and the foot fitted beside it on the thighs:
    // neither behind the person nor seen through, but no foot was seen.
    let Some(body) = makehuman("") else {
        return;
    };
    let mut cfg = seated(at(1.2, ScriptedPose::Neutral), false);
    cfg.body = body;
    cfg.motion = MotionSpec::Rest;
    cfg.intrinsics = Intrinsics::default();
    cfg.sensor_noise = false;
    cfg.seed = SceneConfig::default().seed + 1;
    let cfg = upper_body(cfg);
    let (shown, frames) = hidden_legs_shown(cfg, 120);
    assert!(frames > 100, "{frames} frames with the legs out of view");
    // (6 of 120 frames failed before the rule for a foot fitted at the hip's height;
    // 1 with it.)
    assert!(
        shown * 100 <= frames,
        "{shown} of {frames} frames show a hidden knee or foot"
    );
}

/// The image row of the top of the head above `head` (camera frame): the first row,
/// from the image's top, with a pixel within 0.25 m of the head's depth in the columns
/// around it.
fn top_of_the_head(
    depth: &airglyph_core::DepthView,
    k: &Intrinsics,
    head: &nalgebra::Point3<f32>,
) -> Option<f32> {
    let (u, _) = k.project(head)?;
    let columns = (u.round() as i64 - 3).max(0) as u32..(u.round() as u32 + 4).min(k.width);
    (0..k.height)
        .find(|&v| {
            columns.clone().any(|c| {
                let mm = depth.get(c, v);
                mm > 0 && (mm as f32 / 1000.0 - head.z).abs() < 0.25
            })
        })
        .map(|v| v as f32)
}

#[test]
fn the_head_is_reported_at_the_top_of_the_head() {
    // Hand-labelled frames put "head" at the top of the head, as a geodesic tracker
    // finds it (pose NOTES, 2026-12-06, evening); the skull's centre lies some 60 px
    // (640×480) under it at 1.2 m.
    let mut bodies = vec![SceneConfig::default().body];
    bodies.extend(makehuman(""));
    for body in bodies {
        for pose in [ScriptedPose::Neutral, ScriptedPose::HandsNearFace] {
            let cfg = upper_body(SceneConfig {
                body: body.clone(),
                ..at(1.2, pose)
            });
            let k = cfg.intrinsics;
            let (img, truth) = Synthesizer::new(cfg).expect("scene").render(0);
            let r = PoseEstimator::new(k, PoseConfig::default()).estimate(img.view());
            assert!(r.person_found, "{pose:?}");
            let head = r.skeleton[Joint::Head];
            let top = top_of_the_head(&img.view(), &k, &head).expect("a head in the image");
            let below = |p| k.project(p).expect("in front").1 - top;
            let (est, tru) = (below(&head), below(&truth.skeleton[Joint::Head]));
            // 320×240 at 1.2 m: a pixel is 4 mm.
            assert!(
                (-2.0..3.0).contains(&tru),
                "{pose:?}: the truth {tru:.1} px under the top"
            );
            // The skull's centre lies 25–35 px under the top; the template's top of the
            // head is MakeHuman's (1–3 px here), and the procedural body's longer neck
            // puts it 9–12 px low.
            assert!(
                est.abs() < 15.0,
                "{pose:?}: the head {est:.1} px under the top"
            );
        }
    }
}

#[test]
fn a_short_person_close_up_is_measured_from_the_top_of_the_head_not_the_chin() {
    // Close up, the chin juts out towards the camera and ends a geodesic path of its
    // own; taken for the head's end, the outline read below it showed a neck and
    // shoulders but no head, and the neck's base was not found: the torso then sat on
    // the template's neck, 10–13 cm high on these bodies.
    for (height_m, distance_m) in [(1.55, 1.0), (1.6, 0.9)] {
        let body = BodySpec::Procedural(airglyph_synth::ProceduralBody {
            height_m,
            build: 1.0,
        });
        let cfg = SceneConfig {
            body,
            ..at(distance_m, ScriptedPose::ArmsAtSides)
        };
        for frame in 0..3 {
            let (r, truth) = single(upper_body(cfg.clone()), frame);
            assert!(r.person_found, "{height_m} m body, frame {frame}");
            let e = error_m(&r.skeleton, &truth.skeleton, Joint::Neck);
            assert!(
                e < 0.09,
                "{height_m} m body, frame {frame}: the neck off by {e:.2} m"
            );
            for j in [Joint::LeftShoulder, Joint::RightShoulder] {
                let e = error_m(&r.skeleton, &truth.skeleton, j);
                assert!(
                    e < 0.05,
                    "{height_m} m body, frame {frame}: {j:?} off by {e:.2} m"
                );
            }
        }
    }
}

#[test]
fn hips_held_just_above_a_desk_they_are_behind_are_reported_hidden() {
    // Seated at a desk, the tall man's torso is longer than the template's and nothing
    // below the desk's edge measures it: the fit holds his pelvis a few centimetres
    // above the edge, where it projects into view though the camera sees little of
    // it. Frames 58 and 59 of this scene reported a hip visible.
    let Some(body) = makehuman("gender=1,height=0.7,weight=0.15,muscle=0.4") else {
        return;
    };
    let cfg = SceneConfig {
        body,
        seed: 23,
        motion: MotionSpec::parse("draw:SQOMKIGECA", None, false).expect("a motion"),
        ..seated(at(1.5, ScriptedPose::Neutral), true)
    };
    let k = qvga();
    for frame in [58, 59] {
        let (r, truth) = single(upper_body(cfg.clone()), frame);
        assert!(r.person_found, "frame {frame}");
        visibility_is_consistent(&r, &k);
        for j in [Joint::Pelvis, Joint::LeftHip, Joint::RightHip] {
            assert!(!truth.skeleton.visible[j.index()], "the desk hides {j:?}");
            assert!(
                !r.skeleton.visible[j.index()],
                "frame {frame}: {j:?} reported visible behind the desk"
            );
        }
    }
}

#[test]
fn a_tall_persons_hanging_arms_reach_their_hands_in_a_single_frame() {
    // The template's arms are the MakeHuman body's, 1.67 m tall; a tall person's hands
    // hang well below them. A single frame learns no length from the fit, but the hand's
    // geodesic maximum lies along the fitted arm, beyond its reach: the arms were held
    // short, the hands 15–18 cm high.
    let body = BodySpec::Procedural(airglyph_synth::ProceduralBody {
        height_m: 1.9,
        build: 1.1,
    });
    let cfg = SceneConfig {
        body,
        ..at(1.8, ScriptedPose::ArmsAtSides)
    };
    let k = qvga();
    for frame in 0..3 {
        let (r, truth) = single(upper_body(cfg.clone()), frame);
        assert!(r.person_found, "frame {frame}");
        visibility_is_consistent(&r, &k);
        for j in ARMS {
            assert!(truth.skeleton.visible[j.index()], "{j:?} in view");
            let e = error_m(&r.skeleton, &truth.skeleton, j);
            let bound = if matches!(j, Joint::LeftHand | Joint::RightHand) {
                0.09
            } else {
                0.06
            };
            assert!(e < bound, "frame {frame}: {j:?} off by {e:.2} m");
        }
    }
}

#[test]
fn a_forearm_folded_back_against_the_head_does_not_move_the_torso() {
    // Drawing high, the forearm folds back until the hand touches the head: arm and
    // head close a loop, and the head's geodesic maximum is a point of its side where
    // the two ways round meet, well below the top of the head. Taken for the top, it
    // moved the torso and the shoulders with it.
    let body = BodySpec::Procedural(airglyph_synth::ProceduralBody {
        height_m: 1.6,
        build: 0.9,
    });
    let cfg = SceneConfig {
        body,
        seed: 51,
        intrinsics: Intrinsics::default(),
        sensor_noise: false,
        motion: MotionSpec::parse("draw:ABCDEFGHIJ", None, false).expect("a motion"),
        ..at(0.95, ScriptedPose::Neutral)
    };
    let (r, truth) = single(upper_body(cfg), 35);
    assert!(r.person_found);
    visibility_is_consistent(&r, &Intrinsics::default());
    for j in [Joint::Neck, Joint::LeftShoulder, Joint::RightShoulder] {
        let e = error_m(&r.skeleton, &truth.skeleton, j);
        assert!(e < 0.08, "{j:?} off by {e:.2} m");
    }
}
