use super::solver::bone_steps;
use super::*;
use crate::body::{BodyConfig, Posed, Shape};
use crate::view::testing::{facing, frame_of, rendered};
use airglyph_core::{Intrinsics, Joint, Skeleton};
use nalgebra::{Unit, Vector3};

/// The MakeHuman template at the default limb lengths, seen by a 320×240 camera.
fn scene() -> (BodyTemplate, Intrinsics) {
    let bones = crate::body::Limbs::from_config(&BodyConfig::default());
    let t = BodyTemplate::from_shape(&Shape::makehuman(), &bones);
    (t, Intrinsics::default().scaled_to(320, 240))
}

/// Nothing hidden last frame.
const SEEN: [f32; Segment::COUNT] = [0.0; Segment::COUNT];

fn worst(t: &BodyTemplate, a: &BodyPose, b: &BodyPose) -> f32 {
    let (sa, sb): (Skeleton, Skeleton) =
        (Posed::new(t, a).skeleton(t), Posed::new(t, b).skeleton(t));
    Joint::ALL
        .iter()
        .map(|&j| (sa[j] - sb[j]).norm())
        .fold(0.0, f32::max)
}

#[test]
fn registration_finds_the_pose_a_body_was_drawn_at() {
    let (t, k) = scene();
    // The truth: turned 20° to its left, the right arm raised forward, the left
    // knee bent.
    let mut truth = facing(Point3::new(0.05, 0.1, 2.6));
    let turn = |axis: Vector3<f32>, a: f32| Unit::new_normalize(axis).into_inner() * a;
    let mut w = [Vector3::zeros(); Segment::COUNT];
    w[Segment::Pelvis.index()] = turn(Vector3::y(), 0.35);
    w[Segment::RightUpperArm.index()] = turn(Vector3::x(), -1.1);
    w[Segment::RightForearm.index()] = turn(Vector3::x(), -0.5);
    w[Segment::LeftShin.index()] = turn(Vector3::x(), 0.6);
    truth.step(&Vector3::zeros(), &w);
    let (points, mask) = rendered(&t, &truth, &k);
    let frame = frame_of(&points, &mask, &k);
    // The start: where a person moving fast was a frame before: 6 cm off, turned
    // 8° less, the arm 11° and 17° lower, the knee straighter.
    let mut start = facing(Point3::new(0.1, 0.13, 2.62));
    let mut w0 = [Vector3::zeros(); Segment::COUNT];
    w0[Segment::Pelvis.index()] = turn(Vector3::y(), 0.2);
    w0[Segment::RightUpperArm.index()] = turn(Vector3::x(), -0.9);
    w0[Segment::RightForearm.index()] = turn(Vector3::x(), -0.2);
    w0[Segment::LeftShin.index()] = turn(Vector3::x(), 0.4);
    start.step(&Vector3::zeros(), &w0);
    // Every pixel a data point, of weight one; without the pull towards hanging,
    // which by design bends a limb the camera hardly sees (this raised arm: 3.6 cm
    // at its worst joint with a pull of 0.1).
    let mut cfg = RegisterConfig::default();
    cfg.solver.iterations = 30;
    cfg.sampling.interior_stride = 1;
    cfg.priors.limb_rest = 0.0;
    let before = worst(&t, &start, &truth);
    assert!(before > 0.1, "the start is {before} m off at worst");
    // The limbs' tips where the geodesic maxima would be: the truth's.
    let posed = Posed::new(&t, &truth);
    let tips = t.tips.map(|(s, local)| Some(posed.point(s, &local)));
    let mut reg = Registration::default();
    reg.prepare(&frame, &cfg.sampling);
    assert!(reg.data_len() > 1000);
    let fit = reg
        .fit(&frame, &t, &racing(vec![start], tips, &cfg), &SEEN, false)
        .expect("a start");
    let after = worst(&t, &fit.pose, &truth);
    assert!(after < 0.02, "worst joint {after} m off after registration");
    // The camera sees the torso and the hanging arm; the raised arm points at it, so
    // its upper part is hidden behind its own hand.
    let seen = fit.seen;
    assert!(seen[Segment::Chest.index()] > 0.8, "{seen:?}");
    assert!(seen[Segment::LeftForearm.index()] > 0.8, "{seen:?}");
    assert!(seen[Segment::RightUpperArm.index()] < 0.3, "{seen:?}");
}

#[test]
fn an_arm_held_out_beside_the_silhouette_is_pulled_back_onto_it() {
    let (t, k) = scene();
    // The truth: standing, arms hanging. The start: the right arm held straight out
    // sideways at shoulder height, over the background, with no geodesic maximum
    // to follow (a T-pose's arm, the person since turned side-on and the arm
    // hidden). Only the silhouette tells it is not there, and the arm lies beside
    // the person's pixels, not above or below them.
    let truth = facing(Point3::new(0.0, 0.1, 2.6));
    let (points, mask) = rendered(&t, &truth, &k);
    let frame = frame_of(&points, &mask, &k);
    let mut start = truth;
    let mut w = [Vector3::zeros(); Segment::COUNT];
    w[Segment::RightUpperArm.index()] = Vector3::z() * 1.5;
    start.step(&Vector3::zeros(), &w);
    let mut cfg = RegisterConfig::default();
    cfg.sampling.interior_stride = 1;
    cfg.priors.limb_rest = 0.0;
    let posed = Posed::new(&t, &truth);
    let mut tips = t.tips.map(|(s, local)| Some(posed.point(s, &local)));
    tips[crate::Limb::RightArm.index()] = None;
    // How far the arm's joints project from the nearest person pixel.
    let off_silhouette = |pose: &BodyPose| {
        let skel = Posed::new(&t, pose).skeleton(&t);
        [Joint::RightElbow, Joint::RightHand].map(|j| {
            let (u, v) = k.project(&skel[j]).expect("in front of the camera");
            (0..mask.len())
                .filter(|&i| mask[i])
                .map(|i| {
                    let w = k.width as usize;
                    let (pu, pv) = ((i % w) as f32, (i / w) as f32);
                    ((pu - u).powi(2) + (pv - v).powi(2)).sqrt()
                })
                .fold(f32::INFINITY, f32::min)
        })
    };
    let before = off_silhouette(&start);
    assert!(before[1] > 20.0, "{before:?} pixels off");
    let mut reg = Registration::default();
    reg.prepare(&frame, &cfg.sampling);
    let fit = reg
        .fit(&frame, &t, &racing(vec![start], tips, &cfg), &SEEN, false)
        .expect("a start");
    let after = off_silhouette(&fit.pose);
    assert!(after.iter().all(|&d| d < 2.0), "{after:?} pixels off");
}

/// A body standing before the camera as the last frame tracked it, and each limb's
/// own tip on it.
fn tracked_with_own_tips() -> (BodyTemplate, BodyPose, [Option<Point3<f32>>; 5]) {
    let (t, _) = scene();
    let tracked = facing(Point3::new(0.0, 0.1, 2.6));
    let posed = Posed::new(&t, &tracked);
    let own = t.tips.map(|(s, local)| Some(posed.point(s, &local)));
    (t, tracked, own)
}

#[test]
fn a_tip_on_another_limb_of_the_tracked_body_is_dropped() {
    use crate::Limb;
    let (t, tracked, own) = tracked_with_own_tips();
    let posed = Posed::new(&t, &tracked);
    let cfg = RegisterConfig::default();
    // Every limb's own tip stays, a hanging hand beside its thigh too.
    let mut tips = own;
    drop_borrowed_tips(&t, &tracked, &mut tips, &cfg.race);
    assert_eq!(tips, own);
    // The right arm given a point of the left forearm (its front, halfway down).
    let c = t
        .capsules
        .iter()
        .find(|c| c.segment == Segment::LeftForearm)
        .expect("a left forearm");
    let mid = Point3::from((c.a.coords + c.b.coords) * 0.5);
    let on_left_forearm = posed.point(c.segment, &mid) - Vector3::z() * c.ra.min(c.rb);
    tips[Limb::RightArm.index()] = Some(on_left_forearm);
    drop_borrowed_tips(&t, &tracked, &mut tips, &cfg.race);
    assert_eq!(tips[Limb::RightArm.index()], None);
    assert_eq!(tips[Limb::LeftArm.index()], own[Limb::LeftArm.index()]);
    // Off, it stays.
    tips[Limb::RightArm.index()] = Some(on_left_forearm);
    let mut off = cfg;
    off.race.borrowed_tip_gap = 0.0;
    drop_borrowed_tips(&t, &tracked, &mut tips, &off.race);
    assert_eq!(tips[Limb::RightArm.index()], Some(on_left_forearm));
}

#[test]
fn only_a_tip_off_the_tracked_body_makes_the_geodesic_estimate_race() {
    use crate::Limb;
    let (t, tracked, own) = tracked_with_own_tips();
    let posed = Posed::new(&t, &tracked);
    let cfg = RegisterConfig::default();
    assert!(!tips_strayed(&t, &tracked, &own, &cfg.race));
    // The left leg's maximum on the front of the right knee: far from the left toes,
    // but on the body.
    let shin = t
        .capsules
        .iter()
        .find(|c| c.segment == Segment::RightShin)
        .expect("a right shin");
    let knee = posed.point(shin.segment, &shin.a) - Vector3::z() * shin.ra;
    let mut tips = own;
    tips[Limb::LeftLeg.index()] = Some(knee);
    let toes = own[Limb::LeftLeg.index()].expect("toes");
    assert!((knee - toes).norm() > cfg.race.gap);
    assert!(!tips_strayed(&t, &tracked, &tips, &cfg.race));
    // Without the surface test it races.
    let mut anywhere = cfg.clone();
    anywhere.race.off_body = 0.0;
    assert!(tips_strayed(&t, &tracked, &tips, &anywhere.race));
    // A hand raised 40 cm before the chest, where the tracked body is not, races.
    let mut tips = own;
    tips[Limb::RightArm.index()] = Some(Point3::new(0.0, -0.2, 2.2));
    assert!(tips_strayed(&t, &tracked, &tips, &cfg.race));
}

#[test]
fn only_a_bent_arm_tells_its_bones_apart() {
    // Σ over residuals of w j j for the two bones' derivatives j = (j1, j2).
    let normal = |js: &[(f64, f64, f64)]| {
        let mut l = [0.0; 5];
        for &(j1, j2, r) in js {
            l[0] += j1 * r;
            l[1] += j2 * r;
            l[2] += j1 * j1;
            l[3] += j1 * j2;
            l[4] += j2 * j2;
        }
        l
    };
    // A straight arm: every residual moves alike whichever bone grows.
    let straight: Vec<_> = (0..40).map(|i| (0.5, 0.4, 0.01 * i as f64)).collect();
    assert_eq!(bone_steps(&normal(&straight), 1.5), None);
    // Bent: some residuals move with one bone only; the steps solve for both.
    let (s1, s2) = (0.03, -0.02);
    let bent: Vec<_> = (0..40)
        .map(|i| {
            let (j1, j2) = if i % 2 == 0 { (0.4, 0.0) } else { (0.2, 0.4) };
            (j1, j2, -(j1 * s1 + j2 * s2))
        })
        .collect();
    let [a, b] = bone_steps(&normal(&bent), 1.5).expect("a bent arm");
    assert!((a as f64 - s1).abs() < 1e-6 && (b as f64 - s2).abs() < 1e-6);
}

#[test]
fn the_better_start_wins_the_race() {
    let (t, k) = scene();
    let truth = facing(Point3::new(0.0, 0.1, 2.6));
    let (points, mask) = rendered(&t, &truth, &k);
    let frame = frame_of(&points, &mask, &k);
    // A start turned half round (back to the camera) cannot reach the truth in a
    // few steps; one a little off can.
    let mut away = truth;
    let mut w = [Vector3::zeros(); Segment::COUNT];
    w[Segment::Pelvis.index()] = Vector3::y() * 2.6;
    away.step(&Vector3::zeros(), &w);
    let mut near = truth;
    near.step(
        &Vector3::new(0.04, -0.03, 0.02),
        &[Vector3::zeros(); Segment::COUNT],
    );
    let mut cfg = RegisterConfig::default();
    cfg.sampling.interior_stride = 1;
    let mut reg = Registration::default();
    reg.prepare(&frame, &cfg.sampling);
    let posed = Posed::new(&t, &truth);
    let tips = t.tips.map(|(s, local)| Some(posed.point(s, &local)));
    for starts in [[away, near], [near, away]] {
        let fit = reg
            .fit(
                &frame,
                &t,
                &racing(starts.to_vec(), tips, &cfg),
                &SEEN,
                false,
            )
            .expect("starts");
        let err = worst(&t, &fit.pose, &truth);
        let (sa, sb) = (
            Posed::new(&t, &fit.pose).skeleton(&t),
            Posed::new(&t, &truth).skeleton(&t),
        );
        for j in Joint::ALL {
            eprintln!("{j:?} {:.3}", (sa[j] - sb[j]).norm());
        }
        assert!(err < 0.02, "worst joint {err} m off");
    }
}

#[test]
fn a_run_that_stops_early_is_measured_where_it_stopped() {
    let (t, k) = scene();
    let truth = facing(Point3::new(0.0, 0.1, 2.6));
    let (points, mask) = rendered(&t, &truth, &k);
    let frame = frame_of(&points, &mask, &k);
    let mut start = truth;
    start.step(
        &Vector3::new(0.04, -0.03, 0.02),
        &[Vector3::zeros(); Segment::COUNT],
    );
    let cfg = RegisterConfig::default();
    let mut reg = Registration::default();
    reg.prepare(&frame, &cfg.sampling);
    let posed = Posed::new(&t, &truth);
    let tips = t.tips.map(|(s, local)| Some(posed.point(s, &local)));
    let problem = Problem {
        frame: &frame,
        body: &t,
        tips: &tips,
        neck: None,
        hidden: &SEEN,
        cfg: &cfg,
    };
    let one = reg.run(&problem, start, 1, true);
    // Every step taken for converged: the run stops after its first, where `one` ends.
    let mut stopping = cfg.clone();
    stopping.solver.converged = f32::MAX;
    let stopped = reg.run(
        &Problem {
            cfg: &stopping,
            ..problem
        },
        start,
        10,
        true,
    );
    assert_eq!(stopped.pose, one.pose);
    assert!(
        (stopped.energy - one.energy).abs() <= 1e-4 * one.energy,
        "stopped early {} against {}",
        stopped.energy,
        one.energy
    );
}

#[test]
fn an_arm_searched_for_does_not_take_the_other_arms_hand() {
    let (t, k) = scene();
    // The truth, 1.2 m away: the left arm hanging at the side, against the body, with
    // no geodesic maximum; the right forearm held forward before the chest. Searched on
    // its own, the left arm explains more points on the right forearm than on itself.
    let mut truth = facing(Point3::new(0.0, 0.1, 1.2));
    let mut w = [Vector3::zeros(); Segment::COUNT];
    w[Segment::RightUpperArm.index()] = Vector3::x() * -0.6;
    w[Segment::RightForearm.index()] = Vector3::x() * -1.0;
    truth.step(&Vector3::zeros(), &w);
    let (points, mask) = rendered(&t, &truth, &k);
    let frame = frame_of(&points, &mask, &k);
    // The start: the left arm across the chest, its hand on the right one.
    let mut crossed = Posed::new(&t, &truth).skeleton(&t);
    let (shoulder, hand) = (crossed[Joint::LeftShoulder], crossed[Joint::RightHand]);
    crossed.set(
        Joint::LeftElbow,
        nalgebra::center(&shoulder, &hand) + Vector3::new(0.0, 0.05, -0.1),
    );
    crossed.set(Joint::LeftHand, hand + Vector3::new(0.03, 0.0, 0.0));
    let start = BodyPose::from_skeleton(&t, &crossed).expect("a body");
    let mut cfg = RegisterConfig::default();
    cfg.sampling.interior_stride = 1;
    let posed = Posed::new(&t, &truth);
    let mut tips = t.tips.map(|(s, local)| Some(posed.point(s, &local)));
    tips[crate::Limb::LeftArm.index()] = None;
    let mut reg = Registration::default();
    reg.prepare(&frame, &cfg.sampling);
    let left_hand_off = |pose: &BodyPose| {
        (Posed::new(&t, pose).skeleton(&t)[Joint::LeftHand] - posed.skeleton(&t)[Joint::LeftHand])
            .norm()
    };
    assert!(left_hand_off(&start) > 0.3);
    let fit = reg
        .fit(&frame, &t, &racing(vec![start], tips, &cfg), &SEEN, true)
        .expect("a start");
    let off = left_hand_off(&fit.pose);
    assert!(off < 0.05, "the left hand {off} m off");
}

/// Starts that follow the tips, with the settings `cfg`.
fn racing(
    poses: Vec<BodyPose>,
    tips: [Option<Point3<f32>>; 5],
    cfg: &RegisterConfig,
) -> Starts<'_> {
    Starts {
        poses,
        free: Vec::new(),
        cfg: std::borrow::Cow::Borrowed(cfg),
        tips,
        neck: None,
    }
}
