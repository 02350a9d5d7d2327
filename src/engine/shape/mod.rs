//! Non-spherical particle shapes: segment geometry, the spherocylinder (mass, inertia, contacts)
//! and the orientation and rotational dynamics of a rigid body.

mod quat;
mod rigid;
mod segment;
mod spherocylinder;

pub use quat::{sin_cos, Quat};
pub use rigid::{
    angular_momentum, angular_velocity, euler_rhs, rotate_free, rotate_free_split,
    rotate_free_symmetric, rotational_energy,
};
pub use segment::{
    closest_point_on_segment, closest_points, ClosestPoints, PARALLEL_SIN, POINT_LEN2,
};
pub use spherocylinder::{
    axis_distance2, contact_plane, contact_sphere, contact_spherocylinders, PairContact,
    PlaneContact, Spherocylinder,
};
