//! One hair's per-frame buffers of the solver step, kept between frames.

use bevy::math::{Affine3A, Vec3A};

use super::contact::LocalShape;
use super::solver::StepInput;
use super::wind::HairForceField;

/// A collider shape over one frame: its pose last frame and now, the shape in its space, and
/// whether particles are kept inside it.
pub(super) type ShapeView = (Affine3A, Affine3A, LocalShape, bool);

/// One hair's per-frame buffers, kept between frames so a steady frame allocates none of them.
#[derive(Clone, Debug, Default)]
pub struct StepScratch {
    pub(super) input: StepInput,
    pub(super) templates: Vec<ShapeView>,
    /// Each template's poses taken apart, to interpolate per substep.
    pub(super) paths: Vec<super::step::Between>,
    pub(super) fields: Vec<(Affine3A, Affine3A, HairForceField)>,
    /// Each template's origin at the previous substep (friction follows its motion).
    pub(super) origins: Vec<Vec3A>,
    /// Anchor factors per node, for each chain length.
    pub(super) factors: Vec<(usize, Vec<f32>)>,
    /// The colliders near the hair this frame (indices into the frame's colliders).
    pub(super) near: Vec<u32>,
}

impl StepScratch {
    /// Where each buffer's memory is and how much it holds: equal across two frames when
    /// nothing was reallocated.
    #[cfg(test)]
    pub(crate) fn footprint(&self) -> Vec<(usize, usize)> {
        fn of<T>(v: &Vec<T>) -> (usize, usize) {
            (v.as_ptr() as usize, v.capacity())
        }
        let i = &self.input;
        let mut out = vec![
            of(&i.bones),
            of(&i.spheres),
            of(&i.sphere_shift),
            of(&i.contacts),
            of(&i.fields),
            of(&i.bone_motion),
            of(&i.carry),
            of(&self.templates),
            of(&self.paths),
            of(&self.fields),
            of(&self.origins),
            of(&self.factors),
            of(&self.near),
        ];
        out.extend(self.factors.iter().map(|(_, f)| of(f)));
        out
    }
}
