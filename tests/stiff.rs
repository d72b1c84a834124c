//! The stiff and extreme cases of raylume's intersection layer: one test per case of the table in
//! `tests/common/robustness_cases.rs` (ids as in ../shared/robustness-cases.md, plus raylume's own
//! O1–O5), each asserting the case's pass criterion and printing its figures.
//!
//! Run in release mode: `cargo test --release --test stiff -- --nocapture` shows the figures, and
//! `cargo run --release --example robustness` prints them as a table beside naive routines'.

#[path = "common/robustness_cases.rs"]
mod cases;

/// Runs the case `id` of the table and asserts its criterion.
fn run(id: &str) {
    let case = cases::CASES.iter().find(|c| c.id == id).unwrap_or_else(|| panic!("no case {id} in the table"));
    let outcome = (case.run)();
    println!("{id}: {}", outcome.figure);
    if let Some(naive) = &outcome.naive {
        println!("{id}, naive: {naive}");
    }
    assert!(
        outcome.failures.is_empty(),
        "{id} {} ({}) fails \"{}\": {}",
        case.title,
        case.setup,
        case.criterion,
        outcome.failures.join("; ")
    );
}

/// One `#[test]` per case id, and the list of the ids tested.
macro_rules! case_tests {
    ($($name:ident => $id:literal,)*) => {
        $(
            #[test]
            fn $name() {
                run($id);
            }
        )*
        const TESTED: &[&str] = &[$($id),*];
    };
}

case_tests! {
    t1_watertight_closed_icosphere => "T1",
    t4_tiny_and_needle_triangles => "T4",
    t6_degenerate_triangles_are_nan_free => "T6",
    t7_grazing_and_parallel_rays => "T7",
    t8_vertex_order_invariance => "T8",
    r1_spawned_rays_never_rehit_their_surface => "R1",
    r4_shadow_rays_between_surfaces => "R4",
    r5_hit_point_error_bound_is_valid => "R5",
    s1_small_sphere_far_away => "S1",
    s2_large_sphere_origin_near_surface => "S2",
    s3_origin_inside_a_huge_sphere => "S3",
    s4_tangent_and_silhouette_rays => "S4",
    pl1_plane_nan_safety => "PL1",
    b1_slab_in_face_rays => "B1",
    b2_conservative_far_traversal => "B2",
    b3_box_edges_corners_inside => "B3",
    b4_signed_zero_invariance => "B4",
    x1_accelerators_on_adversarial_scenes => "X1",
    g3_grid_lattice_rays => "G3",
    x2_invalid_rays => "X2",
    o1_images_are_scale_invariant => "O1",
    o2_tiny_and_huge_triangles => "O2",
    o3_moving_spheres_at_shutter_ends => "O3",
    o4_scene_far_from_the_origin => "O4",
    o5_spheres_and_boxes_never_rehit_themselves => "O5",
    o6_nearly_coincident_spheres => "O6",
}

/// Every case of the table has its test, once.
#[test]
fn every_case_is_tested() {
    let table: Vec<&str> = cases::CASES.iter().map(|c| c.id).collect();
    assert_eq!(table, TESTED, "the tests above and the table list different cases");
}
