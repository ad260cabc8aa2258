//! The creature's body: proportions, skeleton and the coarse quad cage.
//!
//! The cage is box-modelled: a torso lattice box (4 × 6 × 2 quads) with the
//! neck/head, two arms, two legs and an optional tail extruded from fixed
//! quad patches of the box. The sequence of extrusions (and so the cage
//! connectivity) never depends on the proportions; only the ring positions
//! and radii do. Every cage vertex carries skinning weights chosen per ring
//! (a joint ring is shared half/half by its two bones), which Catmull–Clark
//! subdivision later turns into smooth per-vertex weights.

use nalgebra::Rotation3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::{Point, Vec3};

/// Bones of the creature, in skeleton order (parents first).
pub const BONE_NAMES: [&str; 13] = [
    "pelvis",
    "chest",
    "head",
    "upper_arm_l",
    "forearm_l",
    "upper_arm_r",
    "forearm_r",
    "thigh_l",
    "shin_l",
    "thigh_r",
    "shin_r",
    "tail_base",
    "tail_tip",
];
/// Number of bones including the tail.
pub const N_BONES: usize = 13;
/// Parent of each bone (`usize::MAX` for the root).
pub const BONE_PARENT: [usize; N_BONES] = [usize::MAX, 0, 1, 1, 3, 1, 5, 0, 7, 0, 9, 0, 11];

pub(crate) const PELVIS: usize = 0;
pub(crate) const CHEST: usize = 1;
pub(crate) const HEAD: usize = 2;
pub(crate) const UPPER_ARM_L: usize = 3;
pub(crate) const FOREARM_L: usize = 4;
pub(crate) const UPPER_ARM_R: usize = 5;
pub(crate) const FOREARM_R: usize = 6;
pub(crate) const THIGH_L: usize = 7;
pub(crate) const SHIN_L: usize = 8;
pub(crate) const THIGH_R: usize = 9;
pub(crate) const SHIN_R: usize = 10;
pub(crate) const TAIL_BASE: usize = 11;
pub(crate) const TAIL_TIP: usize = 12;

/// Per-bone skinning weights of one vertex.
pub type Weights = [f64; N_BONES];

/// Body proportions of one subject (lengths in metres, roughly human-sized).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Proportions {
    pub torso_height: f64,
    pub chest_half_width: f64,
    pub waist_half_width: f64,
    pub hip_half_width: f64,
    pub torso_half_depth: f64,
    pub upper_arm_length: f64,
    pub forearm_length: f64,
    pub hand_length: f64,
    pub arm_radius: f64,
    pub thigh_length: f64,
    pub shin_length: f64,
    pub foot_length: f64,
    pub leg_radius: f64,
    pub neck_length: f64,
    pub head_radius: f64,
    pub snout: f64,
    pub tail_length: f64,
    pub tail_radius: f64,
}

impl Proportions {
    /// The mean subject (all random factors 1).
    pub fn mean() -> Self {
        Proportions {
            torso_height: 0.56,
            chest_half_width: 0.19,
            waist_half_width: 0.15,
            hip_half_width: 0.18,
            torso_half_depth: 0.11,
            upper_arm_length: 0.30,
            forearm_length: 0.27,
            hand_length: 0.13,
            arm_radius: 0.05,
            thigh_length: 0.42,
            shin_length: 0.40,
            foot_length: 0.17,
            leg_radius: 0.072,
            neck_length: 0.09,
            head_radius: 0.11,
            snout: 1.3,
            tail_length: 0.55,
            tail_radius: 0.035,
        }
    }

    /// Proportions of subject `subject` drawn from `seed`: independent
    /// factors for torso width, torso height, arm length, leg length, girth,
    /// head size and tail, each uniform in ±`spread` (clamped to [0, 0.4]).
    pub fn random(seed: u64, subject: usize, spread: f64) -> Self {
        let s = spread.clamp(0.0, 0.4);
        let mut rng = ChaCha8Rng::seed_from_u64(
            seed ^ (subject as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15),
        );
        let mut f = || 1.0 + rng.random_range(-1.0..=1.0) * s;
        let (width, height, arms, legs, girth, head, tail, fore, shin) =
            (f(), f(), f(), f(), f(), f(), f(), f(), f());
        let m = Proportions::mean();
        Proportions {
            torso_height: m.torso_height * height,
            chest_half_width: m.chest_half_width * width,
            waist_half_width: m.waist_half_width * width * girth.sqrt(),
            hip_half_width: m.hip_half_width * width,
            torso_half_depth: m.torso_half_depth * girth,
            upper_arm_length: m.upper_arm_length * arms,
            forearm_length: m.forearm_length * arms * fore,
            hand_length: m.hand_length * arms,
            arm_radius: m.arm_radius * girth,
            thigh_length: m.thigh_length * legs,
            shin_length: m.shin_length * legs * shin,
            foot_length: m.foot_length * legs.sqrt(),
            leg_radius: m.leg_radius * girth,
            neck_length: m.neck_length * height,
            head_radius: m.head_radius * head,
            snout: m.snout * head.sqrt(),
            tail_length: m.tail_length * tail,
            tail_radius: m.tail_radius * girth,
        }
    }
}

/// Rest-pose skeleton: each bone is the segment `head → tail`; a bone
/// rotates about its head (its joint with the parent).
#[derive(Clone, Debug)]
pub struct Skeleton {
    pub head: [Point; N_BONES],
    pub tail: [Point; N_BONES],
    /// Typical radius of the body part around each bone (for the bulge).
    pub radius: [f64; N_BONES],
}

/// A coarse closed quad mesh with per-vertex weights.
#[derive(Clone, Debug)]
pub struct Cage {
    pub vertices: Vec<Vec3>,
    pub quads: Vec<[usize; 4]>,
    pub weights: Vec<Weights>,
}

const NX: usize = 4;
const NY: usize = 6;
const NZ: usize = 2;

fn w1(b: usize) -> Weights {
    let mut w = [0.0; N_BONES];
    w[b] = 1.0;
    w
}

fn w2(a: usize, wa: f64, b: usize) -> Weights {
    let mut w = [0.0; N_BONES];
    w[a] = wa;
    w[b] = 1.0 - wa;
    w
}

/// One cross-section of a limb.
struct Ring {
    centre: Vec3,
    /// Radius along the patch's first and second in-plane axes.
    ru: f64,
    rv: f64,
    weights: Weights,
}

struct Builder {
    vertices: Vec<Vec3>,
    quads: Vec<[usize; 4]>,
    weights: Vec<Weights>,
}

impl Builder {
    /// Extrudes a limb from the patch `region` (face indices) along `rings`.
    /// `u0`, `v0` are the patch's in-plane axes and `n0` its outward normal.
    #[allow(clippy::too_many_arguments)]
    fn limb(
        &mut self,
        region: &[usize],
        n0: Vec3,
        u0: Vec3,
        v0: Vec3,
        rings: &[Ring],
        dome: f64,
        base: Option<(usize, f64)>,
    ) {
        // Patch centre and normalised offsets of its vertices.
        let mut verts: Vec<usize> = region.iter().flat_map(|&f| self.quads[f]).collect();
        verts.sort_unstable();
        verts.dedup();
        // The patch's own (body) vertices partly follow the limb.
        if let Some((bone, share)) = base {
            for &v in &verts {
                let w = &mut self.weights[v];
                for x in w.iter_mut() {
                    *x *= 1.0 - share;
                }
                w[bone] += share;
            }
        }
        let c0 = verts.iter().map(|&v| self.vertices[v]).sum::<Vec3>() / verts.len() as f64;
        let hu = verts
            .iter()
            .map(|&v| (self.vertices[v] - c0).dot(&u0).abs())
            .fold(0.0, f64::max);
        let hv = verts
            .iter()
            .map(|&v| (self.vertices[v] - c0).dot(&v0).abs())
            .fold(0.0, f64::max);
        // Offsets on the unit circle (square patch boundary → circle).
        let offset = |p: Vec3| -> (f64, f64) {
            let a = (p - c0).dot(&u0) / hu.max(1e-12);
            let b = (p - c0).dot(&v0) / hv.max(1e-12);
            let n = (a * a + b * b).sqrt();
            if n < 1e-9 {
                (0.0, 0.0)
            } else {
                (a / n, b / n)
            }
        };
        let mut offs: std::collections::HashMap<usize, (f64, f64)> = verts
            .iter()
            .map(|&v| (v, offset(self.vertices[v])))
            .collect();
        let mut prev = c0;
        for (k, ring) in rings.iter().enumerate() {
            let next = rings.get(k + 1).map(|r| r.centre);
            let dir = match next {
                Some(n) => (n - prev).normalize(),
                None => (ring.centre - prev).normalize(),
            };
            let rot = Rotation3::rotation_between(&n0, &dir).unwrap_or_else(Rotation3::identity);
            let (u, v) = (rot * u0, rot * v0);
            let last = k + 1 == rings.len();
            let pos = |(a, b): (f64, f64)| -> Vec3 {
                let p = ring.centre + u * (ring.ru * a) + v * (ring.rv * b);
                if a == 0.0 && b == 0.0 && last {
                    p + dir * dome
                } else {
                    p
                }
            };
            let moved = self.extrude(region);
            for (old, new) in moved {
                let o = offs[&old];
                offs.insert(new, o);
                self.vertices[new] = pos(o);
                self.weights[new] = ring.weights;
            }
            // Interior (cap) vertices of the region follow the ring.
            for &f in region {
                for vi in self.quads[f] {
                    let o = offs[&vi];
                    if o == (0.0, 0.0) {
                        self.vertices[vi] = pos(o);
                        self.weights[vi] = ring.weights;
                    }
                }
            }
            prev = ring.centre;
        }
    }

    /// Extrudes the face set `region`: duplicates its boundary loop, joins
    /// old and new loops with wall quads and rewires the region faces to the
    /// new loop. Returns (old, new) vertex pairs, in boundary order.
    fn extrude(&mut self, region: &[usize]) -> Vec<(usize, usize)> {
        let in_region = |a: usize, b: usize, quads: &[[usize; 4]]| {
            region.iter().any(|&f| {
                let q = quads[f];
                (0..4).any(|k| q[k] == a && q[(k + 1) % 4] == b)
            })
        };
        let mut boundary = Vec::new();
        for &f in region {
            let q = self.quads[f];
            for k in 0..4 {
                let (a, b) = (q[k], q[(k + 1) % 4]);
                if !in_region(b, a, &self.quads) {
                    boundary.push((a, b));
                }
            }
        }
        let mut map: Vec<(usize, usize)> = Vec::new();
        let mut new_of = |old: usize, verts: &mut Vec<Vec3>, ws: &mut Vec<Weights>| -> usize {
            if let Some(&(_, n)) = map.iter().find(|(o, _)| *o == old) {
                return n;
            }
            verts.push(verts[old]);
            ws.push(ws[old]);
            map.push((old, verts.len() - 1));
            verts.len() - 1
        };
        let mut walls = Vec::new();
        for &(a, b) in &boundary {
            let na = new_of(a, &mut self.vertices, &mut self.weights);
            let nb = new_of(b, &mut self.vertices, &mut self.weights);
            walls.push([a, b, nb, na]);
        }
        for &f in region {
            for vi in self.quads[f].iter_mut() {
                if let Some(&(_, n)) = map.iter().find(|(o, _)| o == vi) {
                    *vi = n;
                }
            }
        }
        self.quads.extend(walls);
        map
    }
}

/// Half width of the torso at lattice row `j` (0 = hips, NY = shoulders).
fn torso_half_width(p: &Proportions, j: usize) -> f64 {
    let t = j as f64 / NY as f64;
    if t < 0.5 {
        let s = t / 0.5;
        p.hip_half_width + (p.waist_half_width - p.hip_half_width) * s
    } else {
        let s = ((t - 0.5) / 0.5).min(1.0);
        p.waist_half_width + (p.chest_half_width - p.waist_half_width) * s.sqrt()
    }
}

/// Height of the hips above the ground (feet rest at y ≈ 0).
fn hip_height(p: &Proportions) -> f64 {
    p.thigh_length + p.shin_length + 0.6 * p.leg_radius
}

/// Builds the rest skeleton and cage of a subject. The cage connectivity
/// depends only on `tail`.
pub fn build(p: &Proportions, tail: bool) -> (Skeleton, Cage) {
    let y0 = hip_height(p);
    let h = p.torso_height;
    let hd = p.torso_half_depth;
    // Torso lattice surface.
    let mut index = std::collections::HashMap::new();
    let mut b = Builder {
        vertices: Vec::new(),
        quads: Vec::new(),
        weights: Vec::new(),
    };
    for j in 0..=NY {
        for k in 0..=NZ {
            for i in 0..=NX {
                let on_surface = i == 0 || i == NX || j == 0 || j == NY || k == 0 || k == NZ;
                if !on_surface {
                    continue;
                }
                let hw = torso_half_width(p, j);
                let x = (2.0 * i as f64 / NX as f64 - 1.0) * hw;
                let y = y0 + h * j as f64 / NY as f64;
                // Slightly deeper chest, rounder belly.
                let depth = hd * (1.0 + 0.12 * (j as f64 / NY as f64));
                let z = (2.0 * k as f64 / NZ as f64 - 1.0) * depth;
                index.insert((i, j, k), b.vertices.len());
                b.vertices.push(Vec3::new(x, y, z));
                // Spine blend over three rows so a bent torso stays smooth.
                b.weights.push(match j {
                    0 | 1 => w1(PELVIS),
                    2 => w2(PELVIS, 0.8, CHEST),
                    3 => w2(PELVIS, 0.5, CHEST),
                    4 => w2(PELVIS, 0.2, CHEST),
                    _ => w1(CHEST),
                });
            }
        }
    }
    // Faces of the six sides, each cell's quad wound outward.
    let cell = |a: (usize, usize, usize),
                b2: (usize, usize, usize),
                c: (usize, usize, usize),
                d: (usize, usize, usize),
                out: Vec3,
                b: &mut Builder| {
        let q = [index[&a], index[&b2], index[&c], index[&d]];
        let v = &b.vertices;
        let n = (v[q[2]] - v[q[0]]).cross(&(v[q[3]] - v[q[1]]));
        if n.dot(&out) >= 0.0 {
            b.quads.push(q);
        } else {
            b.quads.push([q[0], q[3], q[2], q[1]]);
        }
        b.quads.len() - 1
    };
    let mut side_x = [Vec::new(), Vec::new()];
    let mut bottom = Vec::new();
    let mut top = Vec::new();
    let mut back = Vec::new();
    for (s, &i) in [0usize, NX].iter().enumerate() {
        let out = Vec3::new(if i == 0 { -1.0 } else { 1.0 }, 0.0, 0.0);
        for j in 0..NY {
            for k in 0..NZ {
                let f = cell(
                    (i, j, k),
                    (i, j + 1, k),
                    (i, j + 1, k + 1),
                    (i, j, k + 1),
                    out,
                    &mut b,
                );
                side_x[s].push((j, k, f));
            }
        }
    }
    for (s, &j) in [0usize, NY].iter().enumerate() {
        let out = Vec3::new(0.0, if j == 0 { -1.0 } else { 1.0 }, 0.0);
        for i in 0..NX {
            for k in 0..NZ {
                let f = cell(
                    (i, j, k),
                    (i + 1, j, k),
                    (i + 1, j, k + 1),
                    (i, j, k + 1),
                    out,
                    &mut b,
                );
                if s == 0 {
                    bottom.push((i, k, f));
                } else {
                    top.push((i, k, f));
                }
            }
        }
    }
    for &k in &[0usize, NZ] {
        let out = Vec3::new(0.0, 0.0, if k == 0 { -1.0 } else { 1.0 });
        for i in 0..NX {
            for j in 0..NY {
                let f = cell(
                    (i, j, k),
                    (i + 1, j, k),
                    (i + 1, j + 1, k),
                    (i, j + 1, k),
                    out,
                    &mut b,
                );
                if k == 0 {
                    back.push((i, j, f));
                }
            }
        }
    }
    let pick = |cells: &[(usize, usize, usize)], ok: &dyn Fn(usize, usize) -> bool| -> Vec<usize> {
        cells.iter().filter(|c| ok(c.0, c.1)).map(|c| c.2).collect()
    };
    let (ex, ey, ez) = (Vec3::x(), Vec3::y(), Vec3::z());

    // Skeleton joints.
    let spine = Vec3::new(0.0, y0 + 0.5 * h, 0.0);
    let pelvis = Vec3::new(0.0, y0 + 0.1 * h, 0.0);
    let neck = Vec3::new(0.0, y0 + h - 0.3 * p.neck_length, 0.0);
    let head_centre = neck + ey * (p.neck_length * 1.3 + p.head_radius);
    let shoulder_y = y0 + h * (NY as f64 - 1.0) / NY as f64;
    let hw_top = torso_half_width(p, NY - 1);
    let sh_l = Vec3::new(hw_top - 0.8 * p.arm_radius, shoulder_y, 0.0);
    let el_l = sh_l + ex * p.upper_arm_length;
    let wr_l = el_l + ex * p.forearm_length;
    let hand_l = wr_l + ex * p.hand_length;
    // Keep the thighs apart: the inner side of the first leg ring stays
    // clear of the mid-plane whatever the proportions.
    let hip_x = (0.55 * p.hip_half_width).max(1.35 * p.leg_radius);
    let hip_l = Vec3::new(hip_x, y0 + 0.3 * p.leg_radius, 0.0);
    let kn_l = hip_l - ey * p.thigh_length;
    let an_l = kn_l - ey * p.shin_length;
    let toe_l = an_l + ez * p.foot_length - ey * 0.4 * p.leg_radius;
    let tail0 = Vec3::new(0.0, y0 + 0.5 * h / NY as f64, -0.7 * hd);
    let tail_dir = Vec3::new(0.0, 0.35, -1.0).normalize();
    let tail1 = tail0 + tail_dir * (0.5 * p.tail_length + 0.3 * hd);
    let tail2 = tail1 + Vec3::new(0.0, 0.7, -0.7).normalize() * (0.5 * p.tail_length);
    let mirror = |v: Vec3| Vec3::new(-v.x, v.y, v.z);

    // Neck and head: from the top patch (cells i = 1, 2).
    let top_patch = pick(&top, &|i, _| i == 1 || i == 2);
    let rn = 0.55 * p.head_radius;
    let r = p.head_radius;
    let sn = p.snout;
    let head_rings = [
        Ring {
            centre: neck + ey * (0.7 * p.neck_length),
            ru: rn,
            rv: rn,
            weights: w2(HEAD, 0.6, CHEST),
        },
        Ring {
            centre: head_centre - ey * (0.75 * r),
            ru: 0.75 * r,
            rv: 0.8 * r,
            weights: w1(HEAD),
        },
        Ring {
            centre: head_centre - ey * (0.3 * r) + ez * (0.1 * r),
            ru: 0.98 * r,
            rv: sn * r,
            weights: w1(HEAD),
        },
        Ring {
            centre: head_centre + ey * (0.25 * r) + ez * (0.15 * r),
            ru: 0.95 * r,
            rv: sn * r,
            weights: w1(HEAD),
        },
        Ring {
            centre: head_centre + ey * (0.7 * r) + ez * (0.05 * r),
            ru: 0.6 * r,
            rv: 0.8 * r,
            weights: w1(HEAD),
        },
    ];
    b.limb(
        &top_patch,
        ey,
        ex,
        ez,
        &head_rings,
        0.3 * r,
        Some((HEAD, 0.15)),
    );

    // Arms: side patches, top two rows.
    let ra = p.arm_radius;
    for (s, side) in side_x.iter().enumerate() {
        let m = |v: Vec3| if s == 1 { v } else { mirror(v) };
        let (ua, fa) = if s == 1 {
            (UPPER_ARM_L, FOREARM_L)
        } else {
            (UPPER_ARM_R, FOREARM_R)
        };
        let patch = pick(side, &|j, _| j >= NY - 2);
        let dx = if s == 1 { ex } else { -ex };
        let (sh, el, wr) = (m(sh_l), m(el_l), m(wr_l));
        let rings = [
            Ring {
                centre: sh + dx * (0.35 * p.upper_arm_length),
                ru: 1.15 * ra,
                rv: 1.15 * ra,
                weights: w2(ua, 0.8, CHEST),
            },
            Ring {
                centre: sh + dx * (0.72 * p.upper_arm_length),
                ru: 1.0 * ra,
                rv: 1.0 * ra,
                weights: w1(ua),
            },
            Ring {
                centre: el,
                ru: 0.8 * ra,
                rv: 0.8 * ra,
                weights: w2(ua, 0.5, fa),
            },
            Ring {
                centre: el + dx * (0.33 * p.forearm_length),
                ru: 0.88 * ra,
                rv: 0.85 * ra,
                weights: w1(fa),
            },
            Ring {
                centre: el + dx * (0.7 * p.forearm_length),
                ru: 0.72 * ra,
                rv: 0.68 * ra,
                weights: w1(fa),
            },
            Ring {
                centre: wr,
                ru: 0.58 * ra,
                rv: 0.45 * ra,
                weights: w1(fa),
            },
            Ring {
                centre: wr + dx * (0.5 * p.hand_length),
                ru: 0.95 * ra,
                rv: 0.35 * ra,
                weights: w1(fa),
            },
            Ring {
                centre: wr + dx * p.hand_length,
                ru: 0.6 * ra,
                rv: 0.25 * ra,
                weights: w1(fa),
            },
        ];
        // u = z (front/back, the flat hand's width), v = y.
        b.limb(&patch, dx, ez, ey, &rings, 0.2 * ra, Some((ua, 0.25)));
    }

    // Legs: bottom patches (left leg on +x: cells i = 2, 3).
    let rl = p.leg_radius;
    for s in 0..2 {
        let m = |v: Vec3| if s == 0 { v } else { mirror(v) };
        let (th, shn) = if s == 0 {
            (THIGH_L, SHIN_L)
        } else {
            (THIGH_R, SHIN_R)
        };
        let patch = pick(&bottom, &|i, _| if s == 0 { i >= 2 } else { i < 2 });
        let (hp, kn, an) = (m(hip_l), m(kn_l), m(an_l));
        let rings = [
            Ring {
                centre: hp - ey * (0.3 * p.thigh_length),
                ru: 1.05 * rl,
                rv: 1.1 * rl,
                weights: w2(th, 0.8, PELVIS),
            },
            Ring {
                centre: hp - ey * (0.68 * p.thigh_length),
                ru: 0.9 * rl,
                rv: 0.95 * rl,
                weights: w1(th),
            },
            Ring {
                centre: kn,
                ru: 0.72 * rl,
                rv: 0.75 * rl,
                weights: w2(th, 0.5, shn),
            },
            Ring {
                centre: kn - ey * (0.33 * p.shin_length),
                ru: 0.78 * rl,
                rv: 0.85 * rl,
                weights: w1(shn),
            },
            Ring {
                centre: kn - ey * (0.72 * p.shin_length),
                ru: 0.6 * rl,
                rv: 0.62 * rl,
                weights: w1(shn),
            },
            Ring {
                centre: an + ez * (0.1 * p.foot_length),
                ru: 0.5 * rl,
                rv: 0.55 * rl,
                weights: w1(shn),
            },
            Ring {
                centre: an + ez * (0.5 * p.foot_length) - ey * (0.3 * rl),
                ru: 0.6 * rl,
                rv: 0.3 * rl,
                weights: w1(shn),
            },
            Ring {
                centre: m(toe_l),
                ru: 0.5 * rl,
                rv: 0.22 * rl,
                weights: w1(shn),
            },
        ];
        // u = x (foot width), v = z.
        b.limb(&patch, -ey, ex, ez, &rings, 0.2 * rl, Some((th, 0.25)));
    }

    // Tail: back patch, bottom row, cells i = 1, 2.
    if tail {
        let patch = pick(&back, &|i, j| (i == 1 || i == 2) && j == 0);
        let rt = p.tail_radius;
        let mut rings = Vec::new();
        let n = 6;
        for k in 1..=n {
            let t = k as f64 / n as f64;
            let centre = if t <= 0.5 {
                tail0 + (tail1 - tail0) * (t / 0.5)
            } else {
                tail1 + (tail2 - tail1) * ((t - 0.5) / 0.5)
            };
            let radius = rt * (1.2 - 0.75 * t);
            let weights = match k {
                1 => w2(TAIL_BASE, 0.8, PELVIS),
                3 => w2(TAIL_BASE, 0.5, TAIL_TIP),
                k if k < 3 => w1(TAIL_BASE),
                _ => w1(TAIL_TIP),
            };
            rings.push(Ring {
                centre,
                ru: radius,
                rv: radius,
                weights,
            });
        }
        b.limb(
            &patch,
            -ez,
            ex,
            ey,
            &rings,
            0.5 * rt,
            Some((TAIL_BASE, 0.2)),
        );
    }

    let mut head = [Point::origin(); N_BONES];
    let mut tailp = [Point::origin(); N_BONES];
    let mut radius = [0.0; N_BONES];
    let mut set = |bone: usize, a: Vec3, z: Vec3, r: f64| {
        head[bone] = Point::from(a);
        tailp[bone] = Point::from(z);
        radius[bone] = r;
    };
    set(PELVIS, pelvis, spine, p.hip_half_width);
    set(CHEST, spine, neck, p.chest_half_width);
    set(HEAD, neck, head_centre + ey * r, r);
    set(UPPER_ARM_L, sh_l, el_l, ra);
    set(FOREARM_L, el_l, hand_l, 0.8 * ra);
    set(UPPER_ARM_R, mirror(sh_l), mirror(el_l), ra);
    set(FOREARM_R, mirror(el_l), mirror(hand_l), 0.8 * ra);
    set(THIGH_L, hip_l, kn_l, rl);
    set(SHIN_L, kn_l, an_l, 0.8 * rl);
    set(THIGH_R, mirror(hip_l), mirror(kn_l), rl);
    set(SHIN_R, mirror(kn_l), mirror(an_l), 0.8 * rl);
    set(TAIL_BASE, tail0, tail1, p.tail_radius);
    set(TAIL_TIP, tail1, tail2, 0.7 * p.tail_radius);
    (
        Skeleton {
            head,
            tail: tailp,
            radius,
        },
        Cage {
            vertices: b.vertices,
            quads: b.quads,
            weights: b.weights,
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cage_is_closed_and_connectivity_is_proportion_independent() {
        let (_, a) = build(&Proportions::mean(), true);
        let (_, b) = build(&Proportions::random(7, 3, 0.15), true);
        assert_eq!(a.quads, b.quads);
        let mut directed = std::collections::HashSet::new();
        for q in &a.quads {
            for k in 0..4 {
                assert!(directed.insert((q[k], q[(k + 1) % 4])), "edge twice");
            }
        }
        for &(i, j) in &directed {
            assert!(directed.contains(&(j, i)), "open edge {i}-{j}");
        }
        let v = a.vertices.len() as i64;
        let e = directed.len() as i64 / 2;
        let f = a.quads.len() as i64;
        assert_eq!(v - e + f, 2, "genus 0");
    }
}
