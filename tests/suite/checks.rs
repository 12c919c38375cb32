//! The checks of the library's private parts, one test each. They live
//! beside the code they check, as `checks` modules compiled with the
//! `checks` feature (which `cargo test` turns on), and run here: the
//! library has no unit-test harness, which would compile it a second time.
//! `cargo test --test suite checks::lti_riccati` runs one module's checks.

/// One test module per checked module (`fts::internal_checks::<module>`), one
/// test per check, named as the check.
macro_rules! run_checks {
    ($($module:ident: [$($check:ident),+ $(,)?],)+) => {
        $(
            mod $module {
                $(
                    #[test]
                    fn $check() {
                        fts::internal_checks::$module::$check();
                    }
                )+
            }
        )+
        /// Every module and check this file runs, for the completeness test.
        const LISTED: &[(&str, &[&str])] = &[$((stringify!($module), &[$(stringify!($check)),+])),+];
    };
}

run_checks! {
    cli: [negative_values_reach_their_option, one_file_named_by_two_result_options_is_refused],
    cli_loop_analysis: [the_mixsyn_loop_plot_spans_its_features_not_fourteen_decades],
    cli_manual: [one_page_per_subcommand_each_roff],
    cli_names: [every_setting_is_the_id_of_an_option_of_its_command,
        messages_name_only_flags_of_their_command, a_setting_is_named_as_typed,
        flags_are_found_in_messages, the_leaf_command_is_remembered],
    ident_arx: [noise_free_li21_recovered_to_1e9, equation_error_noise_estimates_within_std_devs,
        criteria_are_matlab_arx_report, errors, reported_std_devs_match_monte_carlo_spread],
    ident_ct: [srivc_recovers_a_third_order_system_from_noise_free_multisine_data,
        srivc_recovers_a_whole_sample_input_delay, srivc_recovers_a_fractional_input_delay,
        srivc_is_consistent_under_output_noise,
        zoh_response_matches_the_periodic_frf_of_sampled_data,
        freq_fit_recovers_a_delayed_third_order_system_from_its_response,
        freq_fit_under_noise_stays_close_to_the_truth, bad_orders_and_delays_are_named],
    ident_ct_zoh: [a_huge_denominator_is_sampled_in_bounded_time,
        delayed_step_of_a_first_order_lag_matches_the_closed_form,
        second_order_step_and_its_derivative_match_the_closed_form],
    ident_data: [detrend_mean_and_linear],
    ident_excite: [triangle_shape, frequencies_beyond_nyquist_and_costly_multisines_are_refused,
        linear_sweep_instantaneous_frequency, multisine_schroeder_peak_and_grid,
        five_leaf_matches_eq13, bad_parameters_name_the_field],
    ident_freq: [welch_recovers_known_response_with_unit_coherence, etfe_exact_for_periodic_input],
    ident_hysteresis_gd: [factor_cost_and_gradient_are_the_residuals,
        lbfgs_reaches_the_least_squares_solution],
    ident_hysteresis_identify: [regressor_columns_match_the_operators],
    ident_hysteresis_inverse: [two_operator_inverse_by_hand],
    ident_hysteresis_lsq: [streaming_qr_matches_known_solution, nnls_hand_example,
        rank_deficiency_is_reported],
    ident_hysteresis_model: [pi_loop_by_hand, block_simulation_equals_sample_by_sample_steps,
        validation_names_the_problem],
    ident_hysteresis_operators: [initial_states_match_math_md,
        zero_threshold_lower_play_is_identity, hand_computed_lower_play, dead_zone_and_grid],
    ident_hysteresis_solve: [pi_solve_equals_the_analytic_inverse,
        mpi_cbrt_and_lower_play_round_trip, out_of_reach_saturates_at_the_closer_end,
        non_increasing_models_are_refused, runtime_rate_stage_is_the_model_bit_for_bit,
        rate_model_solve_round_trips_on_triangles],
    ident_linear: [simulation_prediction_and_fit_distinction, initial_conditions_are_estimated,
        white_noise_passes_and_coloured_fails, criteria_formulas,
        criteria_match_matlab_aic_documentation_example, filter_matches_difference_equation,
        fitted_free_response_is_the_filtered_one],
    ident_correlation: [lagged_sums_are_the_direct_sums],
    ident_ls: [line_fit_closed_form, streaming_equals_dense_across_blocks, errors,
        blocked_equals_direct_least_squares, rank_deficiency_is_detected, kernels_match_faer_qr,
        portable_and_dispatched_fold_agree, non_finite_block_is_reported, halves_equal_one_pass],
    ident_metrics: [nrmse_hand_computed],
    ident_oe: [output_noise_biases_arx_but_not_iv_or_oe, oe_from_arx_start_converges_too,
        broadband_output_noise_arx_coefficients_biased_oe_iv_not,
        oe_and_iv_std_devs_match_monte_carlo_spread],
    ident_periodic: [the_period_of_a_repeated_record_is_found_and_an_aperiodic_one_has_none,
        averaging_whole_periods_gives_the_system_at_its_lines,
        output_noise_averages_down_and_lowers_the_coherence,
        records_too_short_or_without_input_are_refused],
    ident_structure: [constant_input_and_huge_grids_are_refused,
        finds_the_true_structure_and_delay],
    io_controller_file: [sha256_known_vector, json_round_trip_is_exact_and_stable,
        c_header_carries_the_same_numbers, refuses_bad_files,
        every_block_kind_round_trips_byte_identically, c_header_carries_every_block_kind,
        a_type_error_deep_in_a_block_names_its_path, unknown_and_missing_keys_are_named,
        derived_fields_are_checked_against_the_blocks],
    io_controller_file_multiaxis: [json_round_trip_is_exact_and_byte_stable,
        bad_files_name_the_field, the_c_header_is_deterministic_and_carries_every_block],
    io_hysteresis_json: [an_input_beyond_the_identified_range_is_named, round_trip_is_exact,
        input_dead_zone_round_trips, operator_counts_and_magnitudes_are_bounded,
        errors_name_their_path, mismatched_lengths_name_the_field],
    io_mat: [column_syntax, big_endian_and_compact_storage, sixty_four_bit_integers,
        declared_sizes_beyond_the_bytes_are_refused, structure_errors, is_mat_recognises_headers],
    io_plot: [equal_ranges_give_one_scale_and_keep_the_data,
        every_decade_of_a_log_axis_is_labelled, a_staircase_holds_each_sample,
        the_extension_picks_the_format_and_others_are_refused,
        renders_png_with_text_without_system_fonts, renders_svg],
    io_ss_json: [sizes_and_magnitudes_are_bounded, errors_name_their_path,
        reads_interfaces_example_and_round_trips, static_gain_round_trips, errors_name_the_field],
    io_tf_json: [absurd_models_are_refused_naming_the_field, reads_interfaces_example,
        round_trip_is_bit_exact, errors_name_the_field, a_continuous_delay_survives_the_file,
        a_descending_z_file_is_the_same_system],
    io_timeseries: [header_names_and_time, whitespace_dat_headerless_defaults,
        empty_leading_field_counts_as_column_one, errors_name_line_and_field,
        line_numbers_survive_comments_and_blank_lines,
        a_real_gap_is_refused_with_its_line_and_jitter_is_reported,
        time_units_from_names_units_row_and_option,
        semicolon_decimal_comma_units_row_and_forced_delimiters, quoted_fields_crlf_and_bom,
        write_then_read_is_exact, line_map_counts_runs, time_names,
        keep_rows_cuts_both_signals_or_refuses,
        classic_mac_line_ends_and_quotes_within_a_line,
        records_read_in_blocks_and_pieces_keep_order_and_lines, pieces_are_whole_lines,
        long_lines_grow_the_buffers,
        numbers_parse_as_rust_parses_them,
        plain_lines_read_as_the_general_path_reads_them],
    io_zpetc_json: [round_trip_is_exact, an_absurd_preview_is_refused, errors_name_their_path,
        round_trip_with_stable_inversion],
    lti_accurate: [cancellation_is_exact, response_extended_recovers_a_cancelling_dc_gain,
        quotient_and_inverse_reach_double_double],
    lti_balred: [truncation_error_within_the_bound, a_bound_met_with_equality_is_accepted,
        the_mixsyn_controller_reduces_within_its_bound,
        random_stable_systems_reduce_within_their_bound],
    lti_c2d: [expm_is_bounded_and_exact_on_diagonal_and_rotation_matrices,
        tustin_at_an_eigenvalue_names_it, zoh_of_first_order,
        tustin_prewarp_matches_at_the_frequency, unit_bilinear_round_trip],
    lti_convert: [ss_to_tf_round_trip_continuous, logm_inverts_expm,
        d2c_refuses_the_negative_axis_and_the_origin,
        minreal_cancels_pairs_matched_within_the_tolerance, minreal_removes_a_duplicate],
    lti_exact_response: [lattice_state_is_the_zoh_over_the_whole_time,
        first_order_figures_are_the_closed_form],
    lti_filter: [runtime_zpetc_block_matches_tdf_filter_bit_for_bit,
        impulse_response_matches_difference_equation, step_response_settles_to_dc_gain],
    lti_freqresp: [the_hessenberg_response_is_the_dense_one, a_pole_on_the_axis_is_infinite],
    lti_lyapunov: [
        lyapunov_scalar_and_matrix,
        sylvester_general_and_singular,
        real_blocks_and_factors_agree
    ],
    lti_margins: [integrator_with_lag, a_bandwidth_below_the_analysed_range_is_found_not_clamped,
        mismatched_sample_times_are_refused],
    lti_model_check: [a_pair_at_one_is_found_and_a_distant_one_is_not,
        an_undamped_pole_near_minus_one_is_a_trap],
    lti_norms: [h2_norm_of_a_stiff_badly_scaled_realisation, first_order_norms,
        discrete_norm_finds_peaks_below_nyquist, resonance_peak, peaks_at_nyquist_and_at_infinity,
        discrete_h2_with_feedthrough, unstable_is_an_error,
        confirm_extended_replaces_a_cancelled_peak, bilinear_crossings_are_the_pencils,
        the_confirmed_norm_is_exact_on_a_cancelling_pair],
    lti_poly: [from_roots_and_back, reverse_inverts_zeros, arithmetic],
    lti_response: [first_order_step_is_exact_at_the_samples, matlab_discrete_mimo_example,
        second_order_overshoot_matches_the_closed_form, unstable_and_zero_dc_have_no_figures,
        discrete_impulse_is_a_unit_area_pulse, grids_are_bounded],
    lti_riccati: [scalar_care, double_integrator_lqr, scalar_dare, unstabilisable_is_an_error,
        a_vanishing_q_with_a_hurwitz_closed_loop_gives_zero, care_extended_reaches_double_double],
    lti_roots: [quadratic_closed_form, zeros_and_degenerate_cases,
        degree_fifty_roots_of_unity_scaled],
    lti_ss: [tf_round_trip, feedback_of_integrator, lft_matches_feedback, zeros_of_siso,
        bad_dimensions_are_errors],
    lti_stability: [schur_closed_forms, clustered_root_as_stored_is_unstable, hurwitz_closed_forms,
        full_mantissa_coefficients_stop_at_the_work_budget, agrees_with_well_separated_roots,
        certified_never_contradicts_exact, certified_decides_high_degrees,
        winding_decides_degrees_100_to_160, certified_calls_a_root_on_the_boundary_too_close],
    lti_stability_winding: [synthetic_divisions_are_taylor_coefficients,
        counts_roots_inside_closed_forms, counts_roots_left_closed_forms],
    lti_tf: [validation, li21_phase_lag_matches_math_md, feedback_closed_form, continuous_basics,
        a_continuous_delay_turns_the_phase_and_nothing_else,
        minreal_removes_near_cancellations_only],
    lti_zeros: [empty_and_zero_systems_do_not_panic, static_gain_has_no_finite_zeros,
        siso_zero_and_relative_degree, input_free_system_has_its_unobservable_modes_as_zeros,
        spectra_are_made_conjugate_symmetric, tolerance_is_floored_like_ab08nd],
    pipeline_hash: [lock_round_trips],
    pipeline_manifest: [normalises_paths, line_numbers],
    sim_closed_loop: [period_maxima_follow_fractional_edges, divergence_stops_the_run_at_the_bound,
        error_harmonics_recover_a_known_periodic_error],
    sim_contour: [a_discrete_block_steps_its_difference_equation,
        a_ramp_is_tracked_with_the_velocity_over_the_gain,
        cross_coupling_lowers_the_contour_error_of_mismatched_axes,
        the_linear_model_of_a_runtime_pid_is_what_the_runtime_runs,
        an_unstable_axis_is_refused_and_a_biproper_plant_too],
    sim_disturbance: [specs_parse_and_sample_as_written, disturbed_plant_adds_at_input_and_output,
        timed_samples_keep_their_frequency],
    sim_path: [a_known_normal_offset_is_the_known_distance,
        a_tangential_offset_is_missed_by_the_estimate_only, paths_start_at_the_origin_and_close,
        the_square_stops_at_every_corner],
    sim_reference: [step_holds_the_offset_then_the_target, lead_in_is_smooth_and_reaches_the_start,
        five_leaf_is_entered_with_its_own_velocity, sweep_tail_continues_at_the_same_rate],
    sim_reference_resample: [a_line_resampled_is_the_same_line_and_the_same_grid_is_unchanged,
        an_absurd_length_is_refused_before_allocating],
    sim_scurve: [full_profile_has_the_closed_form_durations, acceleration_limit_not_reached,
        karagoz_velocity_is_out_of_reach_on_a_5_mm_side, short_move_without_the_acceleration_limit,
        bad_limits_name_their_field],
    sim_virtual_fts: [fixture_is_valid_and_round_trips, static_gain_and_stroke,
        hysteresis_is_asymmetric_and_about_ten_percent_wide,
        rate_dependence_widens_fast_loops_only, deterministic_for_a_seed, validation_names_fields],
    synth_budget: [rms_matches_the_h2_norm],
    synth_compliance: [a_straight_leaf_is_a_cantilever, fillets_add_in_series_with_the_beam,
        point_hinges_give_the_pseudo_rigid_body_bridge,
        a_point_pivot_gives_the_pseudo_rigid_body_lever, real_hinges_rigid_limit_and_chaining],
    synth_composite: [grammar],
    synth_ding22: [dc_compliance_and_transmissibility, weights_have_their_corner_gains,
        bad_parameters_are_rejected],
    synth_hinf_central: [descriptor_form_is_the_explicit_controller,
        extended_form_is_the_explicit_controller,
        no_subspace_no_descriptor_form],
    synth_dob: [q_has_unity_dc_gain_and_the_binomial_poles,
        nominal_inverse_is_the_plant_inverted_and_nmp_is_refused],
    synth_ilc: [exact_inversion_learns_in_one_trial, trials_learn_on_their_window,
        a_gain_beyond_two_fails_the_condition, divergence_is_growth_past_the_best_trial,
        zero_phase_filter_is_symmetric_convolution],
    synth_mechanism: [lever_limits_energy_and_inverse,
        bridge_limb_limits_stiffness_matrix_peak_and_inverse, li21_eq1_loses_0_55_um_of_10,
        li21_eq2_f_and_its_limits, tang17_home_jacobian_has_the_published_rows,
        forward_kinematics_invert_the_inverse,
        jacobian_is_the_derivative_of_the_inverse_kinematics,
        workspace_respects_the_linearised_bounds],
    synth_pid: [li21_pid_difference_equation, anti_windup_freezes_integral,
        parallel_pid_matches_continuous_at_low_frequency],
    synth_repetitive: [windowed_sinc_has_unit_dc_gain_and_its_cutoff,
        an_ideal_loop_gives_the_closed_form, the_lead_scan_cancels_a_known_delay],
    synth_weights: [makeweight_hits_its_three_gains, karagoz_weights],
    synth_zpetc: [li21_all_zeros_cancelled_eq10, unstable_zero_kept_and_phase_zero,
        unstable_closed_loop_refused_with_its_pole,
        cancelling_a_zero_at_the_unit_circle_is_refused, near_minus_one_zero_refused,
        bad_params_and_dc_zero, many_zeros_near_the_unit_circle_are_no_zero_at_dc,
        a_true_zero_at_dc_is_still_refused, apply_tracks_through_plant,
        series_inverts_outside_zeros_exactly, series_and_zpetc_zeros_together,
        series_tracks_through_a_nonminimum_phase_plant, series_settings_are_checked],
    synth_zpetc_self: [a_good_filter_passes, a_dc_gain_off_by_2e_6_fails_and_1e_7_passes,
        an_unstable_filter_fails_though_its_response_is_one,
        coefficients_too_large_for_their_gain_fail, a_kept_zero_near_one_fails_on_gain,
        a_pair_at_one_fails_several_ways],
    workflow: [settings_in_messages_are_named_as_the_front_end_calls_them,
        numbers_are_printed_for_people, choices_are_the_serde_names, counts_are_whole_numbers],
    workflow_contour: [settings_deserialise_with_their_defaults,
        an_unreachable_velocity_is_said_and_refused_when_strict,
        in_plane_coordinates_are_along_u1_and_the_inclined_u2, bad_settings_name_their_key,
        a_table_too_long_names_the_setting_that_made_it_so],
    workflow_ding22: [sweep_spec, settings_deserialise_with_their_defaults,
        bad_settings_name_their_key, the_study_reports_the_design_and_its_budget],
    workflow_identify_ct: [settings_deserialise_with_defaults_and_bad_ones_name_their_key,
        frd_step_reports_the_exact_model],
    workflow_puu3: [ideal_joint_loops_track_exactly,
        joint_and_task_control_agree_for_small_motions, z_only_motion_barely_couples,
        a_point_outside_the_workspace_is_refused],
    workflow_simulate: [settings_deserialise_with_their_defaults,
        zpetc_on_its_closed_loop_tracks_exactly, a_diverging_loop_names_time_and_cause,
        missing_models_on_a_linear_plant_are_named],
    workflow_zpetc: [defaults_are_the_library_defaults, each_bad_setting_is_named,
        the_filter_times_the_plant_has_zero_phase_and_unit_dc, a_zero_at_dc_is_the_models_fault],
}

/// A check added beside the code but not listed above would never run:
/// every `pub fn name()` of a `checks` module under `src/` must be listed
/// here, and
/// every listed check must exist (the compiler sees to that).
#[test]
fn every_check_in_the_library_is_listed() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut found = Vec::new();
    collect_checks(&root, &root, &mut found);
    let listed: Vec<(String, String)> = LISTED
        .iter()
        .flat_map(|(m, checks)| checks.iter().map(move |c| (m.to_string(), c.to_string())))
        .collect();
    let missing: Vec<_> = found.iter().filter(|c| !listed.contains(c)).collect();
    assert!(
        missing.is_empty(),
        "checks not run by tests/suite/checks.rs: {missing:?}"
    );
    assert_eq!(
        found.len(),
        listed.len(),
        "a listed check was not found under src/"
    );
}

/// (module alias, check name) of every checks module below `dir`: a module
/// `a::b::checks` is listed as `a_b`, `a::b::x_checks` as `a_b_x`.
fn collect_checks(
    root: &std::path::Path,
    dir: &std::path::Path,
    found: &mut Vec<(String, String)>,
) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            collect_checks(root, &path, found);
            continue;
        }
        let rel = path.strip_prefix(root).unwrap().with_extension("");
        let mut parts: Vec<String> = rel
            .iter()
            .map(|p| p.to_string_lossy().into_owned())
            .collect();
        if parts.last().is_some_and(|p| p == "mod") {
            parts.pop();
        }
        let text = std::fs::read_to_string(&path).unwrap();
        if parts.last().is_some_and(|p| p == "checks") {
            parts.pop();
            checks_in(&text, "", &parts.join("_"), found);
            continue;
        }
        let marker = "#[cfg(feature = \"checks\")]\n#[doc(hidden)]\npub mod ";
        for block in text.split(marker).skip(1) {
            let name = block.split(' ').next().unwrap();
            let mut module = parts.clone();
            if let Some(prefix) = name.strip_suffix("_checks") {
                module.push(prefix.to_string());
            }
            let end = block.find("\n}\n").unwrap_or(block.len());
            checks_in(&block[..end], "    ", &module.join("_"), found);
        }
    }
}

fn checks_in(text: &str, indent: &str, module: &str, found: &mut Vec<(String, String)>) {
    let start = format!("{indent}pub fn ");
    for line in text.lines() {
        if let Some(name) = line
            .strip_prefix(&start)
            .and_then(|r| r.strip_suffix("() {"))
        {
            found.push((module.to_string(), name.to_string()));
        }
    }
}
