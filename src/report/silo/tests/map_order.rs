//! The time maps (figs 6–8) go left to right in time, whatever their names' digits.

use crate::report::silo::fields::FieldJob;
use crate::store::fields::FieldSet;

fn map(t: f64) -> FieldSet {
    FieldSet {
        id: 0,
        job_id: 1,
        name: format!("map_t{t:.3}"),
        grid_kind: "rz".into(),
        origin_m: [0.0; 3],
        spacing_m: [0.001, 0.001, 0.0],
        shape: [1, 1, 1],
        kernel_width_m: 0.003,
        cutoff_widths: 3.0,
        t_start_s: t - 0.5,
        t_end_s: t + 0.5,
        samples: 11,
    }
}

#[test]
fn maps_are_ordered_by_time_not_by_name() {
    let job = FieldJob {
        job_id: 1,
        running_on_to_s: None,
        d_m: 0.032,
        f_hz: 0.3,
        particle_d_m: 0.0058,
        silo_radius_m: 0.075,
        q_kg_per_s: Some(0.2),
        sample_interval_s: Some(0.05),
        sets: vec![map(10.0), map(5.0), map(20.0)],
    };
    let names: Vec<&str> = job.maps().iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["map_t5.000", "map_t10.000", "map_t20.000"]);
}
