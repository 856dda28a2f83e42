//! glTF animation: the translation, rotation and scale of every animated node at a time t
//! (`render --frames`), sampled as glTF 2.0 §3.11 defines: STEP, LINEAR (rotations by
//! spherical linear interpolation) and CUBICSPLINE (Hermite, with the keyframes' in- and
//! out-tangents); before the first keyframe the first value, after the last the last.
//!
//! Every animation of the file plays at once from t = 0 (most files have one). Morph-target
//! weights are not supported (the loader reads no morph targets) and are ignored with a
//! warning, as is a second channel for a node's property already animated.

use std::collections::HashMap;

use glam::{DQuat, DVec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::animation::{Interpolation, Property};
use gltf::Document;

use super::data::Reader;
use crate::error::Error;

/// The animated parts of one node's local transform at the sampled time.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NodePose {
    pub translation: Option<DVec3>,
    pub rotation: Option<DQuat>,
    pub scale: Option<DVec3>,
}

/// The animated nodes' transforms at one time, by node index.
#[derive(Clone, Debug, Default)]
pub struct Pose {
    pub nodes: HashMap<usize, NodePose>,
}

/// Whether the file has any animation.
pub fn has_animations(doc: &Document) -> bool {
    doc.animations().len() > 0
}

/// One channel's keyframes: times, and `width` values per keyframe (three times that with
/// CUBICSPLINE: in-tangent, value, out-tangent).
struct Track {
    times: Vec<f64>,
    values: Vec<f64>,
    width: usize,
    interpolation: Interpolation,
}

impl Track {
    /// Value `k` (CUBICSPLINE: its middle element), tangent `which` (0 in, 2 out).
    fn element(&self, k: usize, which: usize) -> &[f64] {
        let per = if self.interpolation == Interpolation::CubicSpline { 3 } else { 1 };
        let at = (k * per + which) * self.width;
        &self.values[at..at + self.width]
    }

    fn value(&self, k: usize) -> &[f64] {
        self.element(k, if self.interpolation == Interpolation::CubicSpline { 1 } else { 0 })
    }

    /// The track at time `t`, component by component (a rotation still to be normalised,
    /// except LINEAR ones, which are slerped: `rotation`).
    fn sample(&self, t: f64, rotation: bool) -> Vec<f64> {
        let n = self.times.len();
        if t <= self.times[0] {
            return self.value(0).to_vec();
        }
        if t >= self.times[n - 1] {
            return self.value(n - 1).to_vec();
        }
        // The keyframe interval [t_k, t_k+1) holding t.
        let k = self.times.partition_point(|&tk| tk <= t) - 1;
        let (t0, t1) = (self.times[k], self.times[k + 1]);
        let dt = t1 - t0;
        let u = (t - t0) / dt;
        let (a, b) = (self.value(k), self.value(k + 1));
        match self.interpolation {
            Interpolation::Step => a.to_vec(),
            Interpolation::Linear if rotation => {
                // Keyframes stored as normalized integers are only close to unit length.
                let q0 = DQuat::from_xyzw(a[0], a[1], a[2], a[3]).normalize();
                let q1 = DQuat::from_xyzw(b[0], b[1], b[2], b[3]).normalize();
                q0.slerp(q1, u).to_array().to_vec()
            }
            Interpolation::Linear => a.iter().zip(b).map(|(x, y)| x + (y - x) * u).collect(),
            Interpolation::CubicSpline => {
                let (out_k, in_k1) = (self.element(k, 2), self.element(k + 1, 0));
                let (u2, u3) = (u * u, u * u * u);
                let h00 = 2.0 * u3 - 3.0 * u2 + 1.0;
                let h10 = u3 - 2.0 * u2 + u;
                let h01 = -2.0 * u3 + 3.0 * u2;
                let h11 = u3 - u2;
                (0..self.width)
                    .map(|c| h00 * a[c] + h10 * dt * out_k[c] + h01 * b[c] + h11 * dt * in_k1[c])
                    .collect()
            }
        }
    }
}

/// Reads and checks one channel's sampler.
fn track(reader: &Reader, channel: &gltf::animation::Channel, loc: &str) -> Result<Track, Error> {
    let ctx = reader.ctx;
    let sampler = channel.sampler();
    let sloc = format!("{loc}.sampler (samplers[{}])", sampler.index());
    let times: Vec<f64> = reader
        .floats(&sampler.input(), &format!("{sloc}.input"), Dimensions::Scalar, &[(DataType::F32, false)])?
        .into_iter()
        .map(f64::from)
        .collect();
    if times.is_empty() {
        return Err(ctx.err(format!("{sloc}.input"), "has no keyframes"));
    }
    if let Some(i) = times.windows(2).position(|w| w[1] <= w[0]) {
        return Err(ctx.err(
            format!("{sloc}.input"),
            format!("keyframe times must increase: {} at {} is followed by {}", times[i], i, times[i + 1]),
        ));
    }
    let (dims, width, allowed): (Dimensions, usize, &[(DataType, bool)]) = match channel.target().property() {
        Property::Translation | Property::Scale => (Dimensions::Vec3, 3, &[(DataType::F32, false)]),
        Property::Rotation => (
            Dimensions::Vec4,
            4,
            &[
                (DataType::F32, false),
                (DataType::I8, true),
                (DataType::U8, true),
                (DataType::I16, true),
                (DataType::U16, true),
            ],
        ),
        Property::MorphTargetWeights => unreachable!("weights channels are skipped before"),
    };
    let values: Vec<f64> = reader
        .floats(&sampler.output(), &format!("{sloc}.output"), dims, allowed)?
        .into_iter()
        .map(f64::from)
        .collect();
    let interpolation = sampler.interpolation();
    let per = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
    if values.len() != times.len() * per * width {
        return Err(ctx.err(
            format!("{sloc}.output"),
            format!(
                "holds {} values for {} keyframes; {:?} interpolation needs {}",
                values.len() / width,
                times.len(),
                interpolation,
                times.len() * per
            ),
        ));
    }
    Ok(Track { times, values, width, interpolation })
}

/// The time `t` as keyframe times are stored: f32. An exporter writes frame k at 24 fps as
/// f32(k/24), which is often a little more than k/24; compared in f64, frame k would fall
/// just before its own keyframe and a STEP channel would show the previous key.
pub fn keyframe_time(t: f64) -> f64 {
    t as f32 as f64
}

/// The pose of every animated node at time `t` seconds.
pub fn pose_at(reader: &Reader, doc: &Document, t: f64, warnings: &mut Vec<String>) -> Result<Pose, Error> {
    let ctx = reader.ctx;
    let t = keyframe_time(t);
    let mut pose = Pose::default();
    for anim in doc.animations() {
        for channel in anim.channels() {
            let loc = format!("animations[{}].channels[{}]", anim.index(), channel.index());
            let target = channel.target();
            let node = target.node();
            let property = target.property();
            if property == Property::MorphTargetWeights {
                warnings.push(format!("{loc}: morph-target weights are not supported; ignored"));
                continue;
            }
            if let gltf::scene::Transform::Matrix { .. } = node.transform() {
                return Err(ctx.err(
                    format!("{loc}.target"),
                    format!(
                        "animates nodes[{}], which has a matrix: animated nodes must use TRS",
                        node.index()
                    ),
                ));
            }
            let track = track(reader, &channel, &loc)?;
            let v = track.sample(t, property == Property::Rotation);
            let entry = pose.nodes.entry(node.index()).or_default();
            let taken = match property {
                Property::Translation => entry.translation.replace(DVec3::new(v[0], v[1], v[2])).is_some(),
                Property::Scale => entry.scale.replace(DVec3::new(v[0], v[1], v[2])).is_some(),
                Property::Rotation => {
                    let q = DQuat::from_xyzw(v[0], v[1], v[2], v[3]);
                    if q.length() == 0.0 {
                        return Err(
                            ctx.err(format!("{loc}.sampler"), format!("the rotation at t = {t} is zero"))
                        );
                    }
                    entry.rotation.replace(q.normalize()).is_some()
                }
                Property::MorphTargetWeights => false,
            };
            if taken {
                warnings.push(format!(
                    "{loc}: nodes[{}] {property:?} is animated by an earlier channel; this one is ignored",
                    node.index()
                ));
            }
        }
    }
    Ok(pose)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track(times: &[f64], values: &[f64], width: usize, interpolation: Interpolation) -> Track {
        Track { times: times.to_vec(), values: values.to_vec(), width, interpolation }
    }

    #[test]
    fn step_and_linear_hold_the_ends_and_interpolate_between() {
        let lin = track(&[1.0, 3.0], &[0.0, 10.0, 4.0, 20.0], 2, Interpolation::Linear);
        assert_eq!(lin.sample(0.0, false), vec![0.0, 10.0]);
        assert_eq!(lin.sample(2.0, false), vec![2.0, 15.0]);
        assert_eq!(lin.sample(9.0, false), vec![4.0, 20.0]);
        let step = track(&[1.0, 3.0], &[0.0, 10.0, 4.0, 20.0], 2, Interpolation::Step);
        assert_eq!(step.sample(2.9, false), vec![0.0, 10.0]);
        assert_eq!(step.sample(3.0, false), vec![4.0, 20.0]);
    }

    #[test]
    fn frame_times_meet_their_f32_keyframes() {
        // Keyframes at frames 0, 8 and 11 of 24 fps, as an exporter stores them (f32 rounds
        // both up).
        let times: Vec<f64> = [0.0, 8.0 / 24.0, 11.0 / 24.0].iter().map(|&t: &f64| t as f32 as f64).collect();
        let step = track(&times, &[0.0, 1.0, 2.0], 1, Interpolation::Step);
        assert!(8.0 / 24.0 < times[1], "the f32 keyframe is after the f64 frame time");
        assert_eq!(step.sample(8.0 / 24.0, false), vec![0.0], "compared in f64, frame 8 misses its key");
        assert_eq!(step.sample(keyframe_time(8.0 / 24.0), false), vec![1.0]);
        assert_eq!(step.sample(keyframe_time(11.0 / 24.0), false), vec![2.0]);
    }

    #[test]
    fn linear_rotations_slerp() {
        let h = std::f64::consts::FRAC_1_SQRT_2;
        // Identity to 90° about y: halfway is 45°.
        let rot = track(&[0.0, 1.0], &[0.0, 0.0, 0.0, 1.0, 0.0, h, 0.0, h], 4, Interpolation::Linear);
        let v = rot.sample(0.5, true);
        let q = DQuat::from_xyzw(v[0], v[1], v[2], v[3]);
        let expect = DQuat::from_rotation_y(std::f64::consts::FRAC_PI_4);
        assert!(q.angle_between(expect) < 1e-12, "{q:?}");
    }

    #[test]
    fn cubic_splines_pass_through_keyframes_and_follow_tangents() {
        // One component, keyframes (0, 0) and (2, 1), tangents 0: smoothstep.
        let c = track(&[0.0, 2.0], &[9.0, 0.0, 0.0, 0.0, 1.0, 9.0], 1, Interpolation::CubicSpline);
        assert_eq!(c.sample(0.0, false), vec![0.0]);
        assert_eq!(c.sample(2.0, false), vec![1.0]);
        assert!((c.sample(1.0, false)[0] - 0.5).abs() < 1e-15);
        assert!((c.sample(0.5, false)[0] - 0.15625).abs() < 1e-15);
        // Tangent 1 (per second) at both ends, values 0 and 2 over 2 s: the line v = t.
        let line = track(&[0.0, 2.0], &[0.0, 0.0, 1.0, 1.0, 2.0, 0.0], 1, Interpolation::CubicSpline);
        assert!((line.sample(0.5, false)[0] - 0.5).abs() < 1e-15);
    }
}
