//! Scripted poses stay within joint limits, the arm IK reaches what it can, and a
//! following camera keeps the person in place.

use airglyph_core::Joint;
use airglyph_synth::poses::{arm_ik, neutral, Side};
use airglyph_synth::{
    Body, Bone, Placement, ProceduralBody, SceneConfig, ScriptedPose, Synthesizer,
};
use nalgebra::{Point3, Vector3};

fn dir(p: &airglyph_synth::Pose, b: Bone) -> Vector3<f32> {
    p.get(b) * b.tpose_dir()
}

#[test]
fn scripted_poses_respect_joint_limits() {
    let body = Body::procedural(&ProceduralBody::default()).unwrap();
    for pose in ScriptedPose::ALL {
        let p = pose.pose(body.tpose());
        for (up, fore, hand) in [
            (Bone::LeftUpperArm, Bone::LeftForearm, Bone::LeftHand),
            (Bone::RightUpperArm, Bone::RightForearm, Bone::RightHand),
        ] {
            // Elbow: a hinge that flexes 0–150°, never backwards.
            let flex = dir(&p, up).angle(&dir(&p, fore)).to_degrees();
            assert!(flex <= 150.0, "{pose:?}: elbow at {flex}°");
            let hinge = p.get(up) * Vector3::z(); // the anterior side of the upper arm
            assert!(
                dir(&p, fore).dot(&hinge) >= -1e-3,
                "{pose:?}: {} bends backwards",
                fore.name()
            );
            // Wrist straight, shoulder not behind the back by more than 60°.
            assert!(dir(&p, fore).angle(&dir(&p, hand)) < 1e-3);
            let back = (p.get(Bone::Chest).inverse() * dir(&p, up)).z;
            assert!(back > -0.87, "{pose:?}: upper arm far behind the back");
        }
        // Legs straight and under the body, spine and head upright.
        for b in [Bone::LeftShin, Bone::RightShin, Bone::Spine, Bone::Head] {
            let local = p.local(b).angle().to_degrees();
            assert!(local < 1.0, "{pose:?}: {} bent {local}°", b.name());
        }
    }
}

#[test]
fn arm_ik_reaches_targets_within_reach() {
    let body = Body::procedural(&ProceduralBody::default()).unwrap();
    let sk = body.tpose();
    let shoulder = sk.joint(Joint::RightShoulder);
    for target in [
        shoulder + Vector3::new(0.0, -0.2, 0.35),
        shoulder + Vector3::new(0.25, 0.1, 0.3),
        shoulder + Vector3::new(-0.3, -0.3, 0.1),
    ] {
        let mut p = neutral(sk);
        arm_ik(
            sk,
            &mut p,
            Side::Right,
            target,
            &Vector3::new(-1.0, -1.0, -0.3),
        );
        let heads = sk.posed_heads(&p);
        let hand = sk.posed_point(&heads, &p, Bone::RightHand, sk.joint(Joint::RightHand));
        assert!(
            (hand - target).norm() < 0.01,
            "{target:?}: reached {hand:?}"
        );
    }
    // Out of reach: the arm points straight at it.
    let far: Point3<f32> = shoulder + Vector3::new(0.0, 0.0, 2.0);
    let mut p = neutral(sk);
    arm_ik(
        sk,
        &mut p,
        Side::Right,
        far,
        &Vector3::new(-1.0, -1.0, -0.3),
    );
    assert!(dir(&p, Bone::RightForearm).angle(&Vector3::z()) < 0.02);
}

#[test]
fn a_following_camera_removes_the_travel_across_the_floor_and_keeps_the_rest() {
    // The scripted poses sway the hips a little across the floor and up and down.
    let scene = |follow| {
        Synthesizer::new(SceneConfig {
            placement: Placement {
                follow,
                ..Placement::default()
            },
            ..SceneConfig::default()
        })
        .unwrap()
    };
    let (free, followed) = (scene(false), scene(true));
    let mut travelled = 0.0f32;
    for i in 0..90 {
        let (a, b) = (free.pose(i), followed.pose(i));
        travelled = travelled.max(a.root.x.abs() + a.root.z.abs());
        assert_eq!((b.root.x, b.root.z), (0.0, 0.0), "frame {i}");
        assert_eq!(a.root.y, b.root.y, "frame {i}: height kept");
    }
    assert!(travelled > 1e-3, "the free person sways: {travelled}");
}
