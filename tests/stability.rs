//! Stiff and extreme cases at test size (`tprf stability` runs them larger): every row
//! against an answer derived independently of the renderer or, for the scales and the
//! 100 000 bins, against the renderer's own equivalent result (an invariance check); no
//! NaN or infinity.

use tprf_core::report::stability::{Row, Size, markdown};

fn all_pass(rows: Vec<Row>) {
    assert!(!rows.is_empty());
    let failed: Vec<Row> = rows.iter().filter(|r| !r.passed()).cloned().collect();
    assert!(failed.is_empty(), "\n{}", markdown(&failed));
}

#[test]
fn stiff_furnaces_follow_the_albedo_laws() {
    all_pass(tprf_core::report::stability::stiff_furnace(Size::Test));
}

#[test]
fn scenes_at_1mm_1m_and_10km_agree() {
    all_pass(tprf_core::report::stability::scales(Size::Test));
}

#[test]
fn one_bin_and_100000_bins_conserve_energy() {
    all_pass(tprf_core::report::stability::bins(Size::Test));
}

#[test]
fn a_point_light_1e_6_m_from_a_wall_stays_finite_and_lights_it() {
    let rows = tprf_core::report::stability::light_near_wall(Size::Test);
    // The pixels away from the light's foot converge normally; the foot's pixel is
    // unbiased with a documented, bounded error.
    all_pass(rows);
}

#[test]
fn grazing_light_and_view_match_the_single_bounce_answer() {
    all_pass(tprf_core::report::stability::grazing(Size::Test));
}

#[test]
fn coincident_and_degenerate_faces_change_nothing() {
    all_pass(tprf_core::report::stability::bad_faces(Size::Test));
}

#[test]
fn cli_writes_the_table() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("stability-{}", std::process::id()));
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_tprf"))
        .args([
            "stability",
            "--size",
            "test",
            "--out",
            dir.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(dir.join("stability.md")).unwrap();
    assert!(
        md.contains("| case | setting | expected | got | relative error | NaN/Inf | verdict |")
    );
    assert!(!md.contains("| FAIL |"));
}

#[test]
fn pulses_and_gates_conserve_energy_or_measure_exactly_zero() {
    all_pass(tprf_core::report::stability::pulses_and_gates(Size::Test));
}

#[test]
fn sensor_noise_and_huge_values_stay_finite_and_non_negative() {
    all_pass(tprf_core::report::stability::sensor_extremes(Size::Test));
}

#[test]
fn spad_at_1e9_cycles_and_saturation_stays_exact() {
    all_pass(tprf_core::report::stability::spad_extremes(Size::Test));
}

#[test]
fn extreme_media_match_single_scattering_and_the_white_furnace_decay() {
    all_pass(tprf_core::report::stability::extreme_media(Size::Test));
}

#[test]
fn a_1_ms_phosphor_on_10_ps_bins_matches_its_closed_form() {
    all_pass(tprf_core::report::stability::stiff_luminescence(Size::Test));
}
