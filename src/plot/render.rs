//! Software mesh renderer for figure panels: orthographic z-buffer
//! rasterisation with Lambert shading under a camera-attached light, per
//! vertex scalar colouring through a [`ColorMap`], and key points drawn as
//! shaded spheres that respect depth.
//!
//! **Camera.** The mesh is rotated about its bounding box centre by
//! `R = Rx(pitch) · Ry(yaw)` (degrees, right-handed, y up); the viewer looks
//! along −z at the rotated mesh, so view space has x to the right, y up and
//! z towards the viewer. Positive yaw turns the model counter-clockwise seen
//! from above (the viewer moves to the model's right); positive pitch tilts
//! its top towards the viewer (seen from above). The projection is
//! orthographic and scaled so the rotated mesh fits its panel with a margin.
//!
//! **Shading.** `ambient + (1 − ambient) · max(0, n·l)` with the light `l`
//! attached to the camera, slightly above and left of the view direction.
//! Back faces (seen through holes of open meshes) are lit with their flipped
//! normal, so they look like the inside of the surface rather than black.
//! Smooth shading interpolates area-weighted vertex normals
//! ([`crate::ops::vertex_normals`]); flat shading uses face normals.
//!
//! **Key points** are spheres of a fixed pixel radius centred at their
//! vertex. Each sphere pixel is depth-tested against the surface: the part
//! in front of the surface is drawn shaded with a dark rim; the part behind
//! it is blended faintly (`hidden_keypoint_alpha`) so points on the far side
//! stay locatable without being mistaken for visible ones.

use crate::ops::{face_normals, vertex_normals};
use crate::{Error, Mesh, Point, Vec3};

use super::output::Image;
use super::style::{keypoint_color, ColorMap};
use super::{Camera, Coloring, Panel, Up};

/// Interpolated or per-face normals.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Shading {
    /// Vertex normals interpolated across faces.
    #[default]
    Smooth,
    /// One normal per face (shows the triangulation).
    Flat,
}

/// Options of the renderer; `Default` gives the paper-figure settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    pub shading: Shading,
    /// Supersampling factor per axis (1 = none; 2 gives 4 samples a pixel).
    pub supersample: u32,
    /// Fraction of the panel kept free around the mesh on each side.
    pub margin: f64,
    /// Key point sphere radius as a fraction of the panel's smaller side.
    pub keypoint_radius: f64,
    /// Opacity of the hidden part of a key point (0 hides it completely).
    pub hidden_keypoint_alpha: f64,
    /// Ambient light fraction.
    pub ambient: f64,
    /// Surface colour of [`Coloring::Plain`].
    pub plain_color: [u8; 3],
    /// Background colour.
    pub background: [u8; 3],
    /// Colour map of [`Coloring::Scalar`] (and of the colour bars).
    pub colormap: ColorMap,
    /// Draw every panel of a figure at the same scale (the smallest of the
    /// per-panel fits), so sizes compare across panels; `false` fits each
    /// panel on its own.
    pub shared_scale: bool,
    /// Panels per row of a figure at most: more panels wrap onto further
    /// rows (0: one row whatever the count). Default
    /// [`DEFAULT_MAX_PER_ROW`].
    pub max_per_row: usize,
}

/// Panels per row of a figure unless [`RenderOptions::max_per_row`] says
/// otherwise.
pub const DEFAULT_MAX_PER_ROW: usize = 6;

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            shading: Shading::Smooth,
            supersample: 2,
            margin: 0.05,
            keypoint_radius: 0.018,
            hidden_keypoint_alpha: 0.3,
            ambient: 0.25,
            plain_color: [200, 200, 206],
            background: [255, 255, 255],
            shared_scale: false,
            colormap: ColorMap::Viridis,
            max_per_row: DEFAULT_MAX_PER_ROW,
        }
    }
}

/// Light direction in view space (unit), towards the light.
fn light_dir() -> Vec3 {
    Vec3::new(-0.25, 0.3, 1.0).normalize()
}

/// The orthographic view of one mesh in one viewport: `project` maps a
/// point to pixel coordinates (x right, y down, origin at the viewport's top
/// left corner, pixel centres at half integers) and a depth (larger is
/// closer to the viewer).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// Rotation from model to view space.
    pub rotation: nalgebra::Matrix3<f64>,
    /// Bounding box centre of the mesh (model space).
    pub centre: Point,
    /// Pixels per model unit.
    pub scale: f64,
    /// Pixel position of the centre.
    pub offset: (f64, f64),
}

impl View {
    /// The rotation of a camera.
    pub fn rotation(camera: Camera) -> nalgebra::Matrix3<f64> {
        let (y, p) = (camera.yaw_deg.to_radians(), camera.pitch_deg.to_radians());
        let ry =
            nalgebra::Matrix3::new(y.cos(), 0.0, y.sin(), 0.0, 1.0, 0.0, -y.sin(), 0.0, y.cos());
        let rx =
            nalgebra::Matrix3::new(1.0, 0.0, 0.0, 0.0, p.cos(), -p.sin(), 0.0, p.sin(), p.cos());
        let up = match camera.up {
            Up::Y => nalgebra::Matrix3::identity(),
            // (x, y, z) → (x, z, −y): +z becomes +y.
            Up::Z => nalgebra::Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0),
        };
        rx * ry * up
    }

    /// Fits `mesh` seen by `camera` into a `width` × `height` viewport,
    /// keeping `margin` (fraction of each side) free, centred.
    pub fn fit(mesh: &Mesh, camera: Camera, width: u32, height: u32, margin: f64) -> View {
        View::fit_at_most(mesh, camera, width, height, margin, f64::INFINITY)
    }

    /// As [`View::fit`], but with at most `max_scale` pixels per model unit
    /// (to give several panels one common scale).
    pub fn fit_at_most(
        mesh: &Mesh,
        camera: Camera,
        width: u32,
        height: u32,
        margin: f64,
        max_scale: f64,
    ) -> View {
        let v = mesh.vertices();
        let (mut lo, mut hi) = (
            Point::new(f64::MAX, f64::MAX, f64::MAX),
            Point::new(f64::MIN, f64::MIN, f64::MIN),
        );
        for p in v {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let centre = nalgebra::center(&lo, &hi);
        let rotation = View::rotation(camera);
        let (mut x0, mut x1, mut y0, mut y1) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for p in v {
            let q = rotation * (p - centre);
            x0 = x0.min(q.x);
            x1 = x1.max(q.x);
            y0 = y0.min(q.y);
            y1 = y1.max(q.y);
        }
        let (w, h) = (width as f64, height as f64);
        let margin = margin.clamp(0.0, 0.45);
        let (aw, ah) = (w * (1.0 - 2.0 * margin), h * (1.0 - 2.0 * margin));
        let (dx, dy) = ((x1 - x0).max(1e-300), (y1 - y0).max(1e-300));
        let scale = (aw / dx).min(ah / dy).min(max_scale);
        // Centre the projected extent (not the bounding box centre, which
        // need not project to the middle of the extent).
        let mid = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
        let offset = (w / 2.0 - scale * mid.0, h / 2.0 + scale * mid.1);
        View {
            rotation,
            centre,
            scale,
            offset,
        }
    }

    /// `(x, y, depth)` of `p` in pixels (depth in model units, larger is
    /// closer).
    pub fn project(&self, p: &Point) -> (f64, f64, f64) {
        let q = self.rotation * (p - self.centre);
        (
            self.offset.0 + self.scale * q.x,
            self.offset.1 - self.scale * q.y,
            q.z,
        )
    }

    /// The same view on a viewport `factor` times larger.
    fn scaled(&self, factor: f64) -> View {
        View {
            scale: self.scale * factor,
            offset: (self.offset.0 * factor, self.offset.1 * factor),
            ..*self
        }
    }
}

/// Checks a panel against its mesh: scalar field length and finiteness,
/// colour range, key point vertices. `what` names the panel in errors.
pub(crate) fn check_panel(panel: &Panel, what: &str) -> crate::Result<()> {
    let n = panel.mesh.n_vertices();
    if let Coloring::Scalar { values, lo, hi, .. } = &panel.coloring {
        if values.len() != n {
            return Err(Error::invalid(format!(
                "{what}: scalar field has {} values but the mesh has {n} vertices",
                values.len()
            )));
        }
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(Error::invalid(format!(
                "{what}: scalar value at vertex {i} is not finite ({})",
                values[i]
            )));
        }
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(Error::invalid(format!(
                "{what}: colour range [{lo}, {hi}] must be finite with lo < hi"
            )));
        }
    }
    for &(v, idx) in &panel.keypoints {
        if v >= n {
            return Err(Error::invalid(format!(
                "{what}: key point {idx} is vertex {v}, but the mesh has {n} vertices"
            )));
        }
    }
    Ok(())
}

/// Floating-point colour + depth buffers at supersampled resolution.
struct Raster {
    color: Vec<[f32; 3]>,
    depth: Vec<f32>,
}

impl Raster {
    fn new(w: usize, h: usize, bg: [u8; 3]) -> Self {
        let c = [bg[0] as f32, bg[1] as f32, bg[2] as f32];
        Raster {
            color: vec![c; w * h],
            depth: vec![f32::NEG_INFINITY; w * h],
        }
    }
}

fn to_f(c: [u8; 3]) -> [f32; 3] {
    [c[0] as f32, c[1] as f32, c[2] as f32]
}

/// Renders one panel's mesh (no text) into a `width` × `height` image with
/// the given view (use [`View::fit`]); validates the panel first.
pub fn render_mesh(
    panel: &Panel,
    view: &View,
    width: u32,
    height: u32,
    opts: &RenderOptions,
) -> crate::Result<Image> {
    check_panel(panel, &format!("panel \"{}\"", panel.label))?;
    if !(1..=8192).contains(&width) || !(1..=8192).contains(&height) {
        return Err(Error::invalid(format!(
            "panel \"{}\": image size {width}×{height} outside 1..=8192 pixels per side",
            panel.label
        )));
    }
    // At most ~8 M samples (16 bytes each) whatever the panel size.
    let mut ss = opts.supersample.clamp(1, 4);
    while ss > 1 && (width * ss) as u64 * (height * ss) as u64 > 8 << 20 {
        ss -= 1;
    }
    let (w, h) = ((width * ss) as usize, (height * ss) as usize);
    let view_s = view.scaled(ss as f64);
    let mesh = &panel.mesh;
    let verts = mesh.vertices();
    let proj: Vec<(f64, f64, f64)> = verts.iter().map(|p| view_s.project(p)).collect();
    let rot = view.rotation;
    let fnormals: Vec<Vec3> = face_normals(mesh).iter().map(|n| rot * n).collect();
    let vnormals: Vec<Vec3> = match opts.shading {
        Shading::Smooth => vertex_normals(mesh).iter().map(|n| rot * n).collect(),
        Shading::Flat => Vec::new(),
    };
    let scalar = match &panel.coloring {
        Coloring::Scalar { values, lo, hi, .. } => Some(
            values
                .iter()
                .map(|v| (v - lo) / (hi - lo))
                .collect::<Vec<f64>>(),
        ),
        Coloring::Plain => None,
    };
    let light = light_dir();
    let ambient = opts.ambient.clamp(0.0, 1.0);
    let plain = to_f(opts.plain_color);
    let mut r = Raster::new(w, h, opts.background);

    for (fi, f) in mesh.faces().iter().enumerate() {
        let [a, b, c] = *f;
        let (pa, pb, pc) = (proj[a], proj[b], proj[c]);
        let area = (pb.0 - pa.0) * (pc.1 - pa.1) - (pb.1 - pa.1) * (pc.0 - pa.0);
        if area.abs() < 1e-12 {
            continue;
        }
        // Facing: the face normal's z in view space (geometric, not the
        // interpolated normal) decides whether this is a back face.
        let fnz = fnormals[fi].z;
        let flip = if fnz < 0.0 { -1.0 } else { 1.0 };
        let xmin = pa.0.min(pb.0).min(pc.0).floor().max(0.0) as usize;
        let xmax = (pa.0.max(pb.0).max(pc.0).ceil() as i64).min(w as i64 - 1);
        let ymin = pa.1.min(pb.1).min(pc.1).floor().max(0.0) as usize;
        let ymax = (pa.1.max(pb.1).max(pc.1).ceil() as i64).min(h as i64 - 1);
        if xmax < 0 || ymax < 0 {
            continue;
        }
        let inv = 1.0 / area;
        for y in ymin..=ymax as usize {
            let py = y as f64 + 0.5;
            for x in xmin..=xmax as usize {
                let px = x as f64 + 0.5;
                // Barycentric weights (signed areas opposite each vertex).
                let wa = ((pb.0 - px) * (pc.1 - py) - (pb.1 - py) * (pc.0 - px)) * inv;
                let wb = ((pc.0 - px) * (pa.1 - py) - (pc.1 - py) * (pa.0 - px)) * inv;
                let wc = 1.0 - wa - wb;
                if wa < 0.0 || wb < 0.0 || wc < 0.0 {
                    continue;
                }
                let z = wa * pa.2 + wb * pb.2 + wc * pc.2;
                let i = y * w + x;
                if (z as f32) <= r.depth[i] {
                    continue;
                }
                let n = match opts.shading {
                    Shading::Smooth => {
                        let n = vnormals[a] * wa + vnormals[b] * wb + vnormals[c] * wc;
                        let len = n.norm();
                        if len > 1e-12 {
                            n / len
                        } else {
                            fnormals[fi]
                        }
                    }
                    Shading::Flat => fnormals[fi],
                } * flip;
                let lambert = n.dot(&light).max(0.0);
                let intensity = (ambient + (1.0 - ambient) * lambert) as f32;
                let base = match &scalar {
                    Some(t) => to_f(opts.colormap.color(wa * t[a] + wb * t[b] + wc * t[c])),
                    None => plain,
                };
                r.depth[i] = z as f32;
                r.color[i] = [
                    base[0] * intensity,
                    base[1] * intensity,
                    base[2] * intensity,
                ];
            }
        }
    }

    // Key points: spheres of a fixed pixel radius.
    let radius_px = opts.keypoint_radius * (width.min(height) as f64) * ss as f64;
    let radius_px = radius_px.max(2.0 * ss as f64);
    let radius_model = radius_px / view_s.scale;
    let alpha_hidden = opts.hidden_keypoint_alpha.clamp(0.0, 1.0) as f32;
    let rim = 1.4 * ss as f64;
    let half = (light + Vec3::new(0.0, 0.0, 1.0)).normalize();
    // Draw far ones first so that nearer spheres' faint parts do not blend
    // over farther spheres.
    let mut order: Vec<usize> = (0..panel.keypoints.len()).collect();
    order.sort_by(|&i, &j| {
        let (zi, zj) = (proj[panel.keypoints[i].0].2, proj[panel.keypoints[j].0].2);
        zi.total_cmp(&zj)
    });
    for k in order {
        let (v, idx) = panel.keypoints[k];
        let (cx, cy, cz) = proj[v];
        let color = to_f(keypoint_color(idx));
        let x0 = (cx - radius_px - 1.0).floor().max(0.0) as usize;
        let x1 = ((cx + radius_px + 1.0).ceil() as i64).min(w as i64 - 1);
        let y0 = (cy - radius_px - 1.0).floor().max(0.0) as usize;
        let y1 = ((cy + radius_px + 1.0).ceil() as i64).min(h as i64 - 1);
        if x1 < 0 || y1 < 0 {
            continue;
        }
        for y in y0..=y1 as usize {
            for x in x0..=x1 as usize {
                let dx = (x as f64 + 0.5 - cx) / radius_px;
                let dy = (y as f64 + 0.5 - cy) / radius_px;
                let d2 = dx * dx + dy * dy;
                if d2 > 1.0 {
                    continue;
                }
                let nz = (1.0 - d2).sqrt();
                let z = cz + nz * radius_model;
                let i = y * w + x;
                let n = Vec3::new(dx, -dy, nz);
                let shade = if d2.sqrt() * radius_px > radius_px - rim {
                    0.35
                } else {
                    let lambert = n.dot(&light).max(0.0);
                    0.3 + 0.7 * lambert
                };
                let spec = if shade > 0.35 {
                    0.35 * n.dot(&half).max(0.0).powi(24)
                } else {
                    0.0
                };
                let c = [
                    (color[0] as f64 * shade + 255.0 * spec).min(255.0) as f32,
                    (color[1] as f64 * shade + 255.0 * spec).min(255.0) as f32,
                    (color[2] as f64 * shade + 255.0 * spec).min(255.0) as f32,
                ];
                if z as f32 >= r.depth[i] {
                    r.color[i] = c;
                    r.depth[i] = z as f32;
                } else if alpha_hidden > 0.0 {
                    let o = r.color[i];
                    r.color[i] = [
                        o[0] + alpha_hidden * (c[0] - o[0]),
                        o[1] + alpha_hidden * (c[1] - o[1]),
                        o[2] + alpha_hidden * (c[2] - o[2]),
                    ];
                }
            }
        }
    }

    // Box filter down to the output size.
    let mut img = Image::new(width, height, opts.background);
    let n = (ss * ss) as f32;
    for y in 0..height as usize {
        for x in 0..width as usize {
            let mut acc = [0f32; 3];
            for sy in 0..ss as usize {
                for sx in 0..ss as usize {
                    let c = r.color[(y * ss as usize + sy) * w + x * ss as usize + sx];
                    for k in 0..3 {
                        acc[k] += c[k];
                    }
                }
            }
            img.set(
                x as u32,
                y as u32,
                [
                    (acc[0] / n).round().clamp(0.0, 255.0) as u8,
                    (acc[1] / n).round().clamp(0.0, 255.0) as u8,
                    (acc[2] / n).round().clamp(0.0, 255.0) as u8,
                ],
            );
        }
    }
    Ok(img)
}
