//! The pose table, forward kinematics, dual-quaternion skinning and the
//! angle-dependent muscle bulge.
//!
//! Posing model (deliberately *not* linear blend skinning, so no method can
//! recover it exactly as "weights × transforms"):
//!
//! 1. Bulge, in rest space: every vertex is pushed along its rest normal by
//!    `r_p · sin²(θ/2) · (A₁ · g(t) · max(0, n·b)² · w_p + A₂ · 4 w_p w_c)`
//!    for each bent hinge (elbows, knees, shoulders, hips, neck), where `θ` is
//!    the child's bend angle, `b` the direction the child swings towards,
//!    `t` the vertex's parameter along the parent bone, `g` a bump centred at
//!    `t = 0.6`, `w_p`, `w_c` the parent / child skinning weights and `r_p`
//!    the parent's girth: a biceps / calf bulge on the inside of the bend
//!    plus a girth increase at the joint, nonlinear in the angle.
//! 2. Dual-quaternion skinning (Kavan et al. 2007) with the smooth,
//!    subdivided cage weights.

use nalgebra::{Quaternion, Unit, UnitQuaternion};

use super::body::*;
use crate::{Point, Vec3};

/// Number of poses in the table.
pub const N_POSES: usize = 10;

/// Short names of the poses.
pub const POSE_NAMES: [&str; N_POSES] = [
    "relaxed",
    "elbows_bent",
    "arms_raised",
    "head_turned_twist",
    "bow",
    "squat",
    "stride",
    "knee_up_side_bend",
    "side_kick_wave",
    "crouch_reach",
];

/// Local joint rotations (rest frame, about each bone's head) of one pose.
pub type Pose = [UnitQuaternion<f64>; N_BONES];

fn rot(axis: Vec3, deg: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Unit::new_normalize(axis), deg.to_radians())
}
fn rx(d: f64) -> UnitQuaternion<f64> {
    rot(Vec3::x(), d)
}
fn ry(d: f64) -> UnitQuaternion<f64> {
    rot(Vec3::y(), d)
}
fn rz(d: f64) -> UnitQuaternion<f64> {
    rot(Vec3::z(), d)
}

/// Mirror of a rotation through the x = 0 plane (left ↔ right).
fn mirror(q: UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    let c = q.into_inner();
    UnitQuaternion::new_unchecked(Quaternion::new(c.w, c.i, -c.j, -c.k))
}

/// Anatomical joint angles (degrees) of one side; converted to rotations
/// in the rest frame. The creature faces +z, its left is +x, y is up; the
/// rest pose is a T-pose.
#[derive(Clone, Copy, Default)]
struct Side {
    /// Arm lowered from the horizontal (positive: down), about z.
    arm_down: f64,
    /// Arm swung forward (positive: towards +z), about y.
    arm_forward: f64,
    /// Elbow flexion (forearm folds forward).
    elbow: f64,
    /// Hip flexion (thigh forward).
    hip: f64,
    /// Hip abduction (leg sideways, outward).
    hip_out: f64,
    /// Knee flexion (shin folds backward).
    knee: f64,
}

#[derive(Clone, Copy, Default)]
struct Spec {
    left: Side,
    right: Side,
    /// Chest: forward bend, side bend (to the creature's left), twist.
    chest_bend: f64,
    chest_side: f64,
    chest_twist: f64,
    /// Head: nod (down), turn (to the left), tilt.
    head_nod: f64,
    head_turn: f64,
    head_tilt: f64,
    /// Whole body turn about the vertical axis.
    root_turn: f64,
    /// Tail: lift (up) and sideways swing, for both tail bones.
    tail_lift: f64,
    tail_swing: f64,
}

fn side_rotations(s: &Side) -> [UnitQuaternion<f64>; 4] {
    // Left side (+x): lowering the arm is a negative rotation about z,
    // swinging it forward a negative rotation about y; elbow flexion folds the
    // forearm forward (about -y); hip flexion is about -x; abduction about +z;
    // knee flexion about +x.
    let shoulder = ry(-s.arm_forward) * rz(-s.arm_down);
    let elbow = ry(-s.elbow);
    let hip = rz(s.hip_out) * rx(-s.hip);
    let knee = rx(s.knee);
    [shoulder, elbow, hip, knee]
}

fn build_pose(s: &Spec) -> Pose {
    let mut p: Pose = [UnitQuaternion::identity(); N_BONES];
    p[PELVIS] = ry(s.root_turn);
    p[CHEST] = ry(s.chest_twist) * rz(-s.chest_side) * rx(s.chest_bend);
    p[HEAD] = ry(s.head_turn) * rz(-s.head_tilt) * rx(s.head_nod);
    let l = side_rotations(&s.left);
    let r = side_rotations(&s.right).map(mirror);
    p[UPPER_ARM_L] = l[0];
    p[FOREARM_L] = l[1];
    p[THIGH_L] = l[2];
    p[SHIN_L] = l[3];
    p[UPPER_ARM_R] = r[0];
    p[FOREARM_R] = r[1];
    p[THIGH_R] = r[2];
    p[SHIN_R] = r[3];
    let tail = rx(s.tail_lift) * ry(s.tail_swing);
    p[TAIL_BASE] = tail;
    p[TAIL_TIP] = tail;
    p
}

/// The fixed pose table shared by every subject (pose `k` of every subject
/// uses exactly these joint angles).
pub fn pose_table() -> [Pose; N_POSES] {
    let arms_down = |d: f64| Side {
        arm_down: d,
        ..Side::default()
    };
    let specs = [
        // 0 relaxed A-pose.
        Spec {
            left: Side {
                elbow: 15.0,
                ..arms_down(55.0)
            },
            right: Side {
                elbow: 15.0,
                ..arms_down(55.0)
            },
            tail_lift: -15.0,
            ..Spec::default()
        },
        // 1 both elbows at 90°, forearms forward; slight knee bend.
        Spec {
            left: Side {
                elbow: 95.0,
                knee: 15.0,
                hip: 8.0,
                ..arms_down(65.0)
            },
            right: Side {
                elbow: 90.0,
                knee: 15.0,
                hip: 8.0,
                ..arms_down(65.0)
            },
            tail_swing: 30.0,
            ..Spec::default()
        },
        // 2 arms raised above the head.
        Spec {
            left: Side {
                arm_down: -70.0,
                elbow: 25.0,
                ..Side::default()
            },
            right: Side {
                arm_down: -60.0,
                elbow: 40.0,
                arm_forward: 20.0,
                ..Side::default()
            },
            head_nod: -20.0,
            tail_lift: 30.0,
            ..Spec::default()
        },
        // 3 head turned, chest twisted.
        Spec {
            left: Side {
                elbow: 30.0,
                arm_forward: 30.0,
                ..arms_down(45.0)
            },
            right: Side {
                elbow: 60.0,
                arm_forward: -20.0,
                ..arms_down(50.0)
            },
            chest_twist: 30.0,
            head_turn: 55.0,
            head_tilt: 10.0,
            root_turn: 20.0,
            tail_swing: -35.0,
            ..Spec::default()
        },
        // 4 bow: torso bent forward, arms hanging forward.
        Spec {
            left: Side {
                arm_forward: 60.0,
                elbow: 20.0,
                knee: 10.0,
                ..arms_down(30.0)
            },
            right: Side {
                arm_forward: 55.0,
                elbow: 25.0,
                knee: 10.0,
                ..arms_down(30.0)
            },
            chest_bend: 35.0,
            head_nod: -25.0,
            tail_lift: 25.0,
            ..Spec::default()
        },
        // 5 squat: hips and knees at ~90°, arms forward.
        {
            // Both sides alike.
            let side = Side {
                arm_forward: 80.0,
                elbow: 30.0,
                hip: 80.0,
                knee: 95.0,
                hip_out: 10.0,
                ..arms_down(10.0)
            };
            Spec {
                left: side,
                right: side,
                chest_bend: 25.0,
                head_nod: -15.0,
                tail_lift: -30.0,
                ..Spec::default()
            }
        },
        // 6 stride: one leg forward with the knee bent, arms swinging.
        Spec {
            left: Side {
                arm_forward: -35.0,
                elbow: 20.0,
                hip: 45.0,
                knee: 70.0,
                ..arms_down(55.0)
            },
            right: Side {
                arm_forward: 40.0,
                elbow: 60.0,
                hip: -20.0,
                knee: 15.0,
                ..arms_down(55.0)
            },
            chest_twist: -12.0,
            head_turn: -15.0,
            tail_swing: 25.0,
            tail_lift: 10.0,
            ..Spec::default()
        },
        // 7 right knee up at 100°, torso bent sideways, head tilted.
        Spec {
            left: Side {
                elbow: 10.0,
                ..arms_down(20.0)
            },
            right: Side {
                elbow: 100.0,
                arm_forward: 30.0,
                hip: 90.0,
                knee: 100.0,
                ..arms_down(60.0)
            },
            chest_side: 20.0,
            head_tilt: -20.0,
            tail_swing: -40.0,
            ..Spec::default()
        },
        // 8 side kick with the left leg, right arm waving.
        Spec {
            left: Side {
                elbow: 45.0,
                hip_out: 28.0,
                knee: 20.0,
                ..arms_down(40.0)
            },
            right: Side {
                arm_down: -45.0,
                elbow: 90.0,
                ..Side::default()
            },
            chest_side: -15.0,
            head_turn: -40.0,
            root_turn: -25.0,
            tail_lift: 20.0,
            ..Spec::default()
        },
        // 9 crouch and reach: deep knee bend, one arm reaching forward.
        Spec {
            left: Side {
                arm_forward: 85.0,
                elbow: 5.0,
                hip: 60.0,
                knee: 75.0,
                ..arms_down(0.0)
            },
            right: Side {
                arm_forward: 20.0,
                elbow: 110.0,
                hip: 35.0,
                knee: 50.0,
                ..arms_down(55.0)
            },
            chest_bend: 30.0,
            chest_twist: 15.0,
            head_nod: 20.0,
            tail_lift: -10.0,
            tail_swing: 45.0,
            ..Spec::default()
        },
    ];
    specs.map(|s| build_pose(&s))
}

/// A rigid transform as a unit dual quaternion `real + ε dual`.
#[derive(Clone, Copy, Debug)]
struct DualQuat {
    real: Quaternion<f64>,
    dual: Quaternion<f64>,
}

impl DualQuat {
    fn from_rt(r: UnitQuaternion<f64>, t: Vec3) -> Self {
        let real = r.into_inner();
        let tq = Quaternion::new(0.0, t.x, t.y, t.z);
        DualQuat {
            real,
            dual: tq * real * 0.5,
        }
    }
}

/// Global rigid transforms (rotation, translation: x ↦ R x + t) of every
/// bone for pose `pose` of skeleton `sk`.
fn bone_transforms(sk: &Skeleton, pose: &Pose) -> [(UnitQuaternion<f64>, Vec3); N_BONES] {
    let mut g = [(UnitQuaternion::identity(), Vec3::zeros()); N_BONES];
    for b in 0..N_BONES {
        // Local: rotate about the joint (bone head in rest space).
        let j = sk.head[b].coords;
        let local_t = j - pose[b] * j;
        let (pr, pt) = if BONE_PARENT[b] == usize::MAX {
            (UnitQuaternion::identity(), Vec3::zeros())
        } else {
            g[BONE_PARENT[b]]
        };
        g[b] = (pr * pose[b], pr * local_t + pt);
    }
    g
}

/// Hinges that bulge: (parent bone, child bone, amplitude of the inner-side
/// muscle bulge, bone whose girth scales the bulge).
const HINGES: [(usize, usize, f64, usize); 8] = [
    (UPPER_ARM_L, FOREARM_L, 0.5, UPPER_ARM_L),
    (UPPER_ARM_R, FOREARM_R, 0.5, UPPER_ARM_R),
    (THIGH_L, SHIN_L, 0.35, THIGH_L),
    (THIGH_R, SHIN_R, 0.35, THIGH_R),
    (CHEST, UPPER_ARM_L, 0.3, UPPER_ARM_L),
    (CHEST, UPPER_ARM_R, 0.3, UPPER_ARM_R),
    (PELVIS, THIGH_L, 0.3, THIGH_L),
    (PELVIS, THIGH_R, 0.3, THIGH_R),
];
/// Amplitude of the girth increase around a bent joint.
const JOINT_SWELL: f64 = 0.15;

/// Poses rest vertices (with rest normals and weights) by bulge + DQS.
pub fn pose_vertices(
    sk: &Skeleton,
    rest: &[Point],
    normals: &[Vec3],
    weights: &[Weights],
    pose: &Pose,
) -> Vec<Point> {
    // Bulged rest positions.
    let mut bulged: Vec<Point> = rest.to_vec();
    for &(parent, child, amp, girth) in &HINGES {
        let theta = pose[child].angle();
        let s = (0.5 * theta).sin().powi(2);
        if s < 1e-12 {
            continue;
        }
        let dc = (sk.tail[child] - sk.head[child]).normalize();
        let swing = pose[child] * dc - dc;
        let b = if swing.norm() > 1e-9 {
            swing.normalize()
        } else {
            Vec3::zeros()
        };
        let (a, z) = (sk.head[parent], sk.tail[parent]);
        let axis = z - a;
        let len2 = axis.norm_squared().max(1e-18);
        let r = sk.radius[girth];
        for (i, x) in rest.iter().enumerate() {
            let (wp, wc) = (weights[i][parent], weights[i][child]);
            if wp <= 0.0 {
                continue;
            }
            let t = ((x - a).dot(&axis) / len2).clamp(-0.5, 1.5);
            let g = (-((t - 0.6) / 0.25).powi(2)).exp();
            let n = normals[i];
            let side = n.dot(&b).max(0.0).powi(2);
            let off = r * s * (amp * g * side * wp + JOINT_SWELL * 4.0 * wp * wc);
            bulged[i] += n * off;
        }
    }
    // Dual-quaternion skinning.
    let dq: Vec<DualQuat> = bone_transforms(sk, pose)
        .iter()
        .map(|&(r, t)| DualQuat::from_rt(r, t))
        .collect();
    bulged
        .iter()
        .zip(weights)
        .map(|(x, w)| {
            let pivot = (0..N_BONES)
                .max_by(|&i, &j| w[i].total_cmp(&w[j]))
                .unwrap_or(0);
            let mut real = Quaternion::new(0.0, 0.0, 0.0, 0.0);
            let mut dual = Quaternion::new(0.0, 0.0, 0.0, 0.0);
            for b in 0..N_BONES {
                if w[b] == 0.0 {
                    continue;
                }
                let sign = if dq[b].real.dot(&dq[pivot].real) < 0.0 {
                    -1.0
                } else {
                    1.0
                };
                real += dq[b].real * (w[b] * sign);
                dual += dq[b].dual * (w[b] * sign);
            }
            let n = real.norm();
            if n < 1e-12 {
                return *x;
            }
            let (real, dual) = (real / n, dual / n);
            let rq = UnitQuaternion::new_unchecked(real);
            let t = (dual * real.conjugate()) * 2.0;
            Point::from(rq * x.coords + Vec3::new(t.i, t.j, t.k))
        })
        .collect()
}
