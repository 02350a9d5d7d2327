//! Non-spherical particle shapes: segment geometry, the spherocylinder (mass, inertia, contacts)
//! and the orientation and rotational dynamics of a rigid body.

mod quat;
mod rigid;
mod segment;
mod spherocylinder;

pub use quat::{is_small_angle, sin_cos, sin_cos_poly, sin_cos_small, Quat, SMALL_ANGLE};
pub use rigid::{
    angular_momentum, angular_velocity, euler_rhs, rotate_free, rotate_free_split,
    rotate_free_symmetric, rotate_symmetric_with, rotational_energy, symmetric_angles,
};
pub use segment::{
    closest_point_on_segment, closest_points, closest_points_in, ClosestPoints, PARALLEL_SIN,
    POINT_LEN2,
};
pub use spherocylinder::{
    contact_plane, contact_sphere, contact_spherocylinders, PairContact, PlaneContact,
    Spherocylinder,
};
