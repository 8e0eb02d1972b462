/*
 * C example and conformance program for the flc-core C interface (include/flc.h).
 *
 * Runs fixed, deterministic input sequences through the FLC, the robust FLC v1 and v2, the PID, the supervisor, the
 * pure-pursuit controller, the lead detector and the neighbour tracker, and prints every output as exact IEEE-754 bit
 * patterns. tests/c_api.rs builds the static library, compiles this file with the system C
 * compiler, runs it and compares every line with the Rust API on the same inputs (the input
 * generators are mirrored in tests/common/mod.rs). It also exercises the error paths (NULL,
 * uninitialised storage, invalid parameters, misaligned points).
 *
 * Build by hand (from crates/flc-core):
 *   cargo rustc --release --no-default-features --features capi,panic-handler \
 *       --crate-type staticlib --config 'profile.release.panic="abort"'
 *   cc -std=c11 -O2 -ffp-contract=off -Iinclude examples/c/main.c \
 *       ../../target/release/libflc_core.a -lm -o flc-example && ./flc-example
 *
 * All storage is static (the detector is ~37 KiB): nothing is allocated anywhere.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "flc.h"

/* ---- deterministic inputs (mirrored in tests/common/mod.rs) --------------------------------- */

typedef struct {
    uint64_t s;
} Lcg;

static uint64_t lcg_next(Lcg *r) {
    r->s = r->s * 6364136223846793005ULL + 1442695040888963407ULL;
    return r->s;
}

static double uniform(Lcg *r) { return (double)(lcg_next(r) >> 11) * (1.0 / 9007199254740992.0); }

static double special(size_t k) {
    switch (k % 5) {
    case 0: return NAN;
    case 1: return INFINITY;
    case 2: return -INFINITY;
    case 3: return -1.0;
    default: return 1.0e9;
    }
}

static uint64_t bits(double v) {
    uint64_t b;
    memcpy(&b, &v, sizeof b);
    return b;
}

static void hash_f64(uint64_t *h, double v) {
    uint64_t b = bits(v);
    for (int i = 0; i < 8; i++) {
        *h ^= (b >> (8 * i)) & 0xff;
        *h *= 0x100000001b3ULL;
    }
}

#define FNV_OFFSET 0xcbf29ce484222325ULL

/* The same synthetic scan as `common::scan`: a car's rear face plus optional guard rails. */
static size_t make_scan(double (*pts)[2], uint64_t seed, double d, double yc, double width, size_t n, int rails) {
    Lcg rng = {seed};
    size_t n_face = rails ? n / 3 : n;
    size_t m = 0;
    for (size_t i = 0; i < n_face; i++) {
        double t = n_face > 1 ? (double)i / (double)(n_face - 1) : 0.5;
        double y = yc - 0.5 * width + width * t;
        double u = 2.0 * t - 1.0;
        double x = d + 0.1 * u * u + 0.04 * (uniform(&rng) - 0.5);
        pts[m][0] = x;
        pts[m][1] = y;
        m++;
    }
    if (rails) {
        size_t n_rail = n - n_face;
        size_t half = n_rail / 2;
        for (int side = 0; side < 2; side++) {
            size_t count = side == 0 ? half : n_rail - half;
            double sign = side == 0 ? 1.0 : -1.0;
            for (size_t j = 0; j < count; j++) {
                double x = 1.0 + 69.0 * ((double)j / (double)count);
                double y = sign * (5.0 + 0.05 * (uniform(&rng) - 0.5));
                pts[m][0] = x;
                pts[m][1] = y;
                m++;
            }
        }
    }
    return m;
}

/* ---- printing --------------------------------------------------------------------------------- */

#define X(v) (unsigned long long)bits(v)

static void print_cmd(const FlcLongitudinalCommand *c) {
    printf(" %u %016llx %016llx", (unsigned)c->status, X(c->speed), X(c->accel));
}

static int failures = 0;

static void check(const char *what, FlcResult r) {
    if (r != FLC_RESULT_OK) {
        printf("FAIL %s: %s\n", what, flc_result_name(r));
        failures++;
    }
}

/* ---- the sequences ------------------------------------------------------------------------------ */

static FlcFallback flc_storage;
static FlcRobust rob_storage;
static FlcRobust2 rob2_storage;
static FlcPid pid_storage;
static FlcSupervisor sup_storage;
static FlcPursuit pp_storage;
static FlcDetector det_storage;
static FlcDetector det2_storage;
static FlcNeighbours nb_storage;
static double scan_buf[1800][2];

static void run_fallback(void) {
    FlcFallbackParams p = flc_fallback_params_default();
    check("flc_fallback_init", flc_fallback_init(&flc_storage, &p, NULL));
    Lcg rng = {1};
    uint64_t h = FNV_OFFSET;
    double dist = 30.0;
    for (size_t k = 0; k < 400; k++) {
        double u1 = uniform(&rng), u2 = uniform(&rng), u3 = uniform(&rng);
        int has = u1 >= 0.05;
        dist += (u2 - 0.55) * 1.2;
        if (dist < 3.0) dist = 40.0;
        double d = dist;
        if (u1 >= 0.05 && u1 < 0.09) d = special(k);
        double v = 25.0 * u3;
        if (u3 >= 0.97) v = special(k + 2);
        hash_f64(&h, d);
        hash_f64(&h, v);
        if (k == 200) check("flc_fallback_reset", flc_fallback_reset(&flc_storage));
        FlcLongitudinalCommand c;
        check("flc_fallback_step", flc_fallback_step(&flc_storage, has, d, v, &c));
        printf("flc %zu", k);
        print_cmd(&c);
        printf("\n");
        FlcFallbackTerms t;
        check("flc_fallback_terms", flc_fallback_terms(&flc_storage, &t));
        printf("flct %zu %016llx %016llx %016llx %016llx %016llx %016llx %016llx %016llx %016llx %d %d\n", k,
               X(t.tau_d), X(t.d_d), X(t.scale_f), X(t.f_shift), X(t.delta_d), X(t.dist_s_raw), X(t.dist_s),
               X(t.a_law), X(t.a), (int)t.braking_branch, (int)t.overridden);
    }
    printf("hash flc %016llx\n", (unsigned long long)h);
}

/* The robust FLC v1 and v2 on the same frames: a drifting distance with jumps up (reveals) and
 * down (cut-ins), missed frames and special values. */
static void run_robust(void) {
    FlcRobustParams p1 = flc_robust_params_default();
    FlcRobust2Params p2 = flc_robust2_params_default();
    check("flc_robust_init", flc_robust_init(&rob_storage, &p1, NULL));
    check("flc_robust2_init", flc_robust2_init(&rob2_storage, &p2, NULL));
    Lcg rng = {7};
    double dist = 30.0;
    for (size_t k = 0; k < 400; k++) {
        double u1 = uniform(&rng), u2 = uniform(&rng), u3 = uniform(&rng);
        int has = u1 >= 0.08;
        dist += (u2 - 0.5) * 0.8;
        if (u2 >= 0.96) dist += 8.0;
        if (u2 < 0.03) dist -= 8.0;
        if (dist < 3.0) dist = 40.0;
        double d = dist;
        if (u1 >= 0.08 && u1 < 0.1) d = special(k);
        double v = 5.0 + 25.0 * u3;
        if (u3 >= 0.98) v = special(k + 1);
        if (k == 250) {
            check("flc_robust_reset", flc_robust_reset(&rob_storage));
            check("flc_robust2_reset", flc_robust2_reset(&rob2_storage));
        }
        FlcLongitudinalCommand c;
        check("flc_robust_step", flc_robust_step(&rob_storage, has, d, v, &c));
        printf("rob %zu", k);
        print_cmd(&c);
        printf("\n");
        FlcRobustTerms t1;
        check("flc_robust_terms", flc_robust_terms(&rob_storage, &t1));
        printf("robt %zu %016llx %016llx %016llx %016llx %016llx %016llx %016llx %d %d\n", k, X(t1.desired_gap), X(t1.gap_error),
               X(t1.gap_speed), X(t1.envelope_speed), X(t1.target_speed), X(t1.latch_min_distance), X(t1.a), (int)t1.revealed,
               (int)t1.latched);
        check("flc_robust2_step", flc_robust2_step(&rob2_storage, has, d, v, &c));
        printf("rob2 %zu", k);
        print_cmd(&c);
        printf("\n");
        FlcRobust2Terms t2;
        check("flc_robust2_terms", flc_robust2_terms(&rob2_storage, &t2));
        printf("rob2t %zu %016llx %016llx %016llx %016llx %016llx %016llx %d %d %d %d\n", k, X(t2.distance), X(t2.gap_speed),
               X(t2.envelope_speed), X(t2.approach_speed), X(t2.target_speed), X(t2.a), (int)t2.held, (int)t2.pending,
               (int)t2.revealed, (int)t2.latched);
    }
}

static void run_pid(void) {
    FlcPidParams p = flc_pid_params_default();
    check("flc_pid_init", flc_pid_init(&pid_storage, &p, NULL));
    Lcg rng = {2};
    uint64_t h = FNV_OFFSET;
    double dist = 25.0;
    const double bad_dt[5] = {NAN, INFINITY, 0.0, -0.05, 20.0};
    for (size_t k = 0; k < 400; k++) {
        double u1 = uniform(&rng), u2 = uniform(&rng), u3 = uniform(&rng), u4 = uniform(&rng), u5 = uniform(&rng);
        double lead = 15.0 + 10.0 * u1;
        if (u5 >= 0.98) lead = special(k);
        double own = 15.0 + 10.0 * u2;
        dist += (u3 - 0.55) * 1.2;
        if (dist < 3.0) dist = 40.0;
        double dt = 0.05;
        if (u3 >= 0.97) dt = bad_dt[k % 5];
        int has = u4 >= 0.03;
        hash_f64(&h, lead);
        hash_f64(&h, own);
        hash_f64(&h, dist);
        hash_f64(&h, dt);
        if (k == 300) check("flc_pid_reset", flc_pid_reset(&pid_storage));
        FlcLongitudinalCommand c;
        check("flc_pid_step", flc_pid_step(&pid_storage, lead, own, has, dist, dt, &c));
        printf("pid %zu", k);
        print_cmd(&c);
        printf("\n");
        FlcPidTerms t;
        check("flc_pid_terms", flc_pid_terms(&pid_storage, &t));
        printf("pidt %zu %016llx %016llx %016llx %016llx %016llx %u\n", k, X(t.desired), X(t.error), X(t.error_rate),
               X(t.integral), X(t.u), (unsigned)t.gains);
    }
    printf("hash pid %016llx\n", (unsigned long long)h);
}

static void run_supervisor(void) {
    FlcSupervisorParams p = flc_supervisor_params_default();
    check("flc_supervisor_init", flc_supervisor_init(&sup_storage, &p, NULL));
    Lcg rng = {3};
    uint64_t h = FNV_OFFSET;
    double dist = 20.0;
    uint32_t seq = 0;
    for (size_t k = 0; k < 600; k++) {
        double u1 = uniform(&rng), u2 = uniform(&rng), u3 = uniform(&rng), u4 = uniform(&rng), u5 = uniform(&rng);
        int has_v2v = u1 < 0.8 && !(k >= 200 && k < 260);
        if (u2 >= 0.05) seq += 1;
        FlcV2vMessage m;
        m.lead_speed = 15.0 + 5.0 * u3;
        if (u2 > 0.98) m.lead_speed = special(k);
        m.seq = seq;
        dist += (u4 - 0.55) * 0.8;
        if (dist < 3.0) dist = 30.0;
        double own = 14.0 + 4.0 * u4;
        int has_dist = u5 >= 0.02;
        hash_f64(&h, m.lead_speed);
        hash_f64(&h, dist);
        hash_f64(&h, own);
        if (k == 450) check("flc_supervisor_reset", flc_supervisor_reset(&sup_storage));
        FlcSupervisorOutput o;
        /* A neighbour entering the path at half the distance on ticks 100-129 (and on 130-139,
           at its double: beyond the lead). */
        int has_intruder = k >= 100 && k < 140;
        double intruder = k < 130 ? 0.5 * dist : 2.0 * dist;
        if (has_intruder)
            check("flc_supervisor_step_intruder",
                  flc_supervisor_step_intruder(&sup_storage, has_v2v, m, has_dist, dist, own, 0.05, true, intruder, &o));
        else
            check("flc_supervisor_step", flc_supervisor_step(&sup_storage, has_v2v, m, has_dist, dist, own, 0.05, &o));
        printf("sup %zu %u %u %d %u %u %u", k, (unsigned)o.active, (unsigned)o.reason, (int)o.switched,
               (unsigned)o.v2v_age_ticks, (unsigned)o.fresh_count, (unsigned)o.association);
        print_cmd(&o.command);
        print_cmd(&o.flc);
        print_cmd(&o.pid);
        printf("\n");
    }
    printf("hash sup %016llx\n", (unsigned long long)h);
}

static void run_pursuit(void) {
    FlcPursuitParams p = flc_pursuit_params_default();
    check("flc_pursuit_init", flc_pursuit_init(&pp_storage, &p, NULL));
    Lcg rng = {4};
    uint64_t h = FNV_OFFSET;
    for (size_t k = 0; k < 200; k++) {
        double u1 = uniform(&rng), u2 = uniform(&rng), u3 = uniform(&rng), u4 = uniform(&rng);
        int has = u1 >= 0.05;
        double x = -5.0 + 60.0 * u2, y = -10.0 + 20.0 * u3, v = 30.0 * u4;
        if (u1 >= 0.05 && u1 < 0.08) x = special(k);
        if (k == 17) x = y = 0.0;
        hash_f64(&h, x);
        hash_f64(&h, y);
        hash_f64(&h, v);
        FlcSteeringCommand s;
        check("flc_pursuit_step", flc_pursuit_step(&pp_storage, has, x, y, v, &s));
        printf("pp %zu %u %016llx %016llx %016llx %016llx %016llx\n", k, (unsigned)s.status, X(s.steer),
               X(s.lookahead), X(s.alpha), X(s.lookahead_x), X(s.lookahead_y));
    }
    printf("hash pp %016llx\n", (unsigned long long)h);
}

static void detect_and_print(FlcDetector *det, const char *label, const double (*pts)[2], size_t n, double curvature) {
    uint64_t h = FNV_OFFSET;
    for (size_t i = 0; i < n; i++) {
        hash_f64(&h, pts[i][0]);
        hash_f64(&h, pts[i][1]);
    }
    hash_f64(&h, curvature);
    FlcDetectorOutput o;
    check("flc_detector_detect", flc_detector_detect(det, n ? &pts[0][0] : NULL, n, curvature, &o));
    const FlcDetection *d = &o.detection;
    printf("det %s %016llx %u %d %016llx %016llx %016llx %016llx %016llx %016llx %zu %zu %zu %zu\n", label,
           (unsigned long long)h, (unsigned)o.status, (int)o.has_detection, X(d->x), X(d->y), X(d->distance),
           X(d->width), X(d->depth), X(d->confidence), d->points, o.points_used, o.points_rejected, o.clusters);
}

static void run_detector(void) {
    FlcDetectorParams p = flc_detector_params_default();
    check("flc_detector_init", flc_detector_init(&det_storage, &p, NULL));
    FlcDetectorParams p2 = p;
    p2.reprojection = FLC_REPROJECTION_CELL_CENTER;
    p2.max_points = 1000;
    check("flc_detector_init 2", flc_detector_init(&det2_storage, &p2, NULL));
    size_t n;

    n = make_scan(scan_buf, 11, 20.0, 0.3, 1.9, 900, 1);
    detect_and_print(&det_storage, "car20_rails_900", (const double (*)[2])scan_buf, n, 0.0);
    detect_and_print(&det_storage, "car20_rails_900_nan_curvature", (const double (*)[2])scan_buf, n, NAN);
    n = make_scan(scan_buf, 12, 45.0, -0.5, 1.8, 1800, 1);
    detect_and_print(&det_storage, "car45_rails_1800", (const double (*)[2])scan_buf, n, -0.0005);
    detect_and_print(&det2_storage, "car45_rails_1800_cell_truncated", (const double (*)[2])scan_buf, n, -0.0005);
    n = make_scan(scan_buf, 13, 30.0, 3.7, 1.9, 600, 0);
    detect_and_print(&det_storage, "next_lane_straight", (const double (*)[2])scan_buf, n, 0.0);
    detect_and_print(&det_storage, "next_lane_curve", (const double (*)[2])scan_buf, n, 0.0082);
    /* The same car on a straight arc with a path profile: the lane moves 3.7 m left by 30 m. */
    static const double bend[4] = {0.0, 1.2, 2.5, 3.7};
    check("flc_detector_set_path_profile", flc_detector_set_path_profile(&det_storage, 10.0, bend, 4, NULL));
    detect_and_print(&det_storage, "next_lane_profile", (const double (*)[2])scan_buf, n, 0.0);
    check("flc_detector_set_path_profile clear", flc_detector_set_path_profile(&det_storage, 0.0, NULL, 0, NULL));
    detect_and_print(&det_storage, "next_lane_profile_cleared", (const double (*)[2])scan_buf, n, 0.0);
    n = make_scan(scan_buf, 14, 25.0, 0.0, 1.9, 900, 1);
    for (size_t i = 0; i < n; i += 50) scan_buf[i][0] = NAN;
    detect_and_print(&det_storage, "car25_nan_points", (const double (*)[2])scan_buf, n, 0.0);
    check("flc_detector_reset", flc_detector_reset(&det_storage));
    detect_and_print(&det_storage, "empty", NULL, 0, 0.0);
}

/* The neighbour tracker behind the detector: a car in the next lane, steady for 15 scans, then
 * changing lanes towards the path (3 m in 40 scans) while the ego closes in; a scan lost at k = 30;
 * on the left, then (after a reset) on the right. */
static void run_neighbours(void) {
    FlcDetectorParams dp = flc_detector_params_default();
    FlcNeighbourParams np = flc_neighbours_params_default();
    check("flc_detector_init nb", flc_detector_init(&det_storage, &dp, NULL));
    check("flc_neighbours_init", flc_neighbours_init(&nb_storage, &np, NULL));
    for (int s = 0; s < 2; s++) {
        double side = s == 0 ? 1.0 : -1.0;
        if (s == 1) check("flc_neighbours_reset", flc_neighbours_reset(&nb_storage));
        for (int k = 0; k < 60; k++) {
            double u = k < 15 ? 0.0 : (k > 55 ? 1.0 : (double)(k - 15) / 40.0);
            double yc = side * (3.5 - 3.0 * u);
            double d = 25.0 - 0.1 * (double)k;
            size_t n = k == 30 ? 0 : make_scan(scan_buf, (uint64_t)(20 + k), d, yc, 1.9, 300, 0);
            FlcDetectorOutput o;
            check("flc_detector_detect nb", flc_detector_detect(&det_storage, n ? &scan_buf[0][0] : NULL, n, 0.0, &o));
            FlcNeighbourOutput r;
            check("flc_neighbours_update", flc_neighbours_update(&nb_storage, &det_storage, &r));
            const FlcDetection *t = &r.detection;
            printf("nb %d %d %d %016llx %016llx %016llx %016llx %016llx %016llx %zu %zu\n", s, k, (int)r.has_detection, X(t->x),
                   X(t->y), X(t->distance), X(t->width), X(t->depth), X(t->confidence), t->points, r.tracks);
        }
    }
}

/* ---- error paths ------------------------------------------------------------------------------ */

static void err_line(const char *what, FlcResult r, const FlcParamError *e) {
    printf("err %s %d %s", what, (int)r, flc_result_name(r));
    if (e) printf(" %s", e->field);
    printf("\n");
}

static void run_errors(void) {
    static FlcFallback zeroed; /* static: all zero, never initialised */
    FlcLongitudinalCommand c;
    FlcParamError e;
    memset(&e, 0, sizeof e);

    err_line("fallback_step_null_self", flc_fallback_step(NULL, true, 20.0, 10.0, &c), NULL);
    err_line("fallback_step_null_out", flc_fallback_step(&flc_storage, true, 20.0, 10.0, NULL), NULL);
    err_line("fallback_step_uninitialised", flc_fallback_step(&zeroed, true, 20.0, 10.0, &c), NULL);
    err_line("fallback_step_wrong_type", flc_fallback_step((FlcFallback *)(void *)&pid_storage, true, 20.0, 10.0, &c), NULL);
    err_line("fallback_reset_uninitialised", flc_fallback_reset(&zeroed), NULL);

    FlcFallbackParams fp = flc_fallback_params_default();
    fp.bound_t = 0.0;
    err_line("fallback_init_bound_t", flc_fallback_init(&zeroed, &fp, &e), &e);
    fp = flc_fallback_params_default();
    fp.dist_override = 7;
    err_line("fallback_init_dist_override", flc_fallback_init(&zeroed, &fp, &e), &e);
    fp = flc_fallback_params_default();
    fp.time_gap = NAN;
    err_line("fallback_init_no_error_struct", flc_fallback_init(&zeroed, &fp, NULL), NULL);
    err_line("fallback_init_null_params", flc_fallback_init(&zeroed, NULL, &e), NULL);
    err_line("fallback_still_uninitialised", flc_fallback_step(&zeroed, true, 20.0, 10.0, &c), NULL);

    static FlcRobust2 zeroed2;
    err_line("robust_step_wrong_type", flc_robust_step((FlcRobust *)(void *)&rob2_storage, true, 20.0, 10.0, &c), NULL);
    err_line("robust2_step_uninitialised", flc_robust2_step(&zeroed2, true, 20.0, 10.0, &c), NULL);
    FlcRobust2Params rp = flc_robust2_params_default();
    rp.sight_decel = 0.0;
    err_line("robust2_init_sight_decel", flc_robust2_init(&zeroed2, &rp, &e), &e);
    rp = flc_robust2_params_default();
    rp.law.first_object = 2;
    err_line("robust2_init_first_object", flc_robust2_init(&zeroed2, &rp, &e), &e);

    FlcPidParams pp = flc_pid_params_default();
    pp.near.kd = -1.0;
    err_line("pid_init_near_kd", flc_pid_init(&pid_storage, &pp, &e), &e);
    /* A failed init leaves an initialised controller untouched. */
    err_line("pid_step_after_failed_init", flc_pid_step(&pid_storage, 10.0, 10.0, true, 20.0, 0.05, &c), NULL);

    FlcSupervisorParams sp = flc_supervisor_params_default();
    sp.return_after = 0;
    err_line("supervisor_init_return_after", flc_supervisor_init(&sup_storage, &sp, &e), &e);
    sp = flc_supervisor_params_default();
    sp.flc.first_frame = 2;
    err_line("supervisor_init_first_frame", flc_supervisor_init(&sup_storage, &sp, &e), &e);
    FlcSupervisorOutput so;
    FlcV2vMessage m = {10.0, 1};
    err_line("supervisor_step_null_out", flc_supervisor_step(&sup_storage, true, m, true, 20.0, 10.0, 0.05, NULL), NULL);

    FlcPursuitParams up = flc_pursuit_params_default();
    up.law = 9;
    err_line("pursuit_init_law", flc_pursuit_init(&pp_storage, &up, &e), &e);
    FlcSteeringCommand sc;
    err_line("pursuit_step_null", flc_pursuit_step(NULL, true, 10.0, 1.0, 5.0, &sc), NULL);

    FlcDetectorParams dp = flc_detector_params_default();
    dp.min_width = 2.0;
    dp.max_width = 1.0;
    err_line("detector_init_max_width", flc_detector_init(&det2_storage, &dp, &e), &e);
    dp = flc_detector_params_default();
    dp.reprojection = 5;
    err_line("detector_init_reprojection", flc_detector_init(&det2_storage, &dp, &e), &e);
    dp = flc_detector_params_default();
    dp.max_points = 0;
    err_line("detector_init_max_points", flc_detector_init(&det2_storage, &dp, &e), &e);
    FlcDetectorOutput o;
    static double aligned[8];
    const double *misaligned = (const double *)(const void *)((const char *)aligned + 1);
    err_line("detector_detect_misaligned", flc_detector_detect(&det_storage, misaligned, 2, 0.0, &o), NULL);
    err_line("detector_detect_null_points", flc_detector_detect(&det_storage, NULL, 5, 0.0, &o), NULL);
    err_line("detector_detect_huge_count", flc_detector_detect(&det_storage, aligned, SIZE_MAX, 0.0, &o), NULL);
    err_line("detector_detect_null_self", flc_detector_detect(NULL, aligned, 4, 0.0, &o), NULL);
    err_line("detector_profile_spacing", flc_detector_set_path_profile(&det_storage, NAN, aligned, 2, &e), &e);
    static double too_many[FLC_PROFILE_STATIONS + 1];
    err_line("detector_profile_count", flc_detector_set_path_profile(&det_storage, 4.0, too_many, FLC_PROFILE_STATIONS + 1, &e), &e);
    err_line("detector_profile_null_offsets", flc_detector_set_path_profile(&det_storage, 4.0, NULL, 3, &e), NULL);
    err_line("supervisor_step_null", flc_supervisor_step(NULL, false, m, true, 20.0, 10.0, 0.05, &so), NULL);

    static FlcNeighbours zeroed_nb;
    static FlcDetector zeroed_det;
    FlcNeighbourParams np = flc_neighbours_params_default();
    np.max_misses = 200;
    err_line("neighbours_init_max_misses", flc_neighbours_init(&zeroed_nb, &np, &e), &e);
    np = flc_neighbours_params_default();
    np.wandering = NAN;
    err_line("neighbours_init_wandering", flc_neighbours_init(&zeroed_nb, &np, &e), &e);
    np = flc_neighbours_params_default();
    np.min_width = 2.0;
    np.max_width = 1.5;
    err_line("neighbours_init_max_width", flc_neighbours_init(&zeroed_nb, &np, &e), &e);
    FlcNeighbourOutput no;
    err_line("neighbours_update_uninitialised", flc_neighbours_update(&zeroed_nb, &det_storage, &no), NULL);
    err_line("neighbours_update_uninitialised_detector", flc_neighbours_update(&nb_storage, &zeroed_det, &no), NULL);
    err_line("neighbours_update_wrong_detector_type", flc_neighbours_update(&nb_storage, (const FlcDetector *)(const void *)&nb_storage, &no), NULL);
    err_line("neighbours_update_null_detector", flc_neighbours_update(&nb_storage, NULL, &no), NULL);
    err_line("neighbours_update_null_out", flc_neighbours_update(&nb_storage, &det_storage, NULL), NULL);
    err_line("neighbours_reset_null", flc_neighbours_reset(NULL), NULL);

    printf("names %s %s %s %s\n", flc_result_name(FLC_RESULT_INVALID_PARAMS), flc_status_name(FLC_STATUS_INVALID_DISTANCE),
           flc_detector_status_name(FLC_DETECTOR_STATUS_EMPTY_SCAN), flc_status_name(200));
    printf("version %s\n", flc_version());
}

int main(void) {
    printf("sizes %zu %zu %zu %zu %zu %zu %zu %zu\n", sizeof(FlcFallback), sizeof(FlcPid), sizeof(FlcSupervisor), sizeof(FlcPursuit),
           sizeof(FlcDetector), sizeof(FlcRobust), sizeof(FlcRobust2), sizeof(FlcNeighbours));
    run_fallback();
    run_robust();
    run_pid();
    run_supervisor();
    run_pursuit();
    run_detector();
    run_neighbours();
    run_errors();
    printf("done %d\n", failures);
    return failures == 0 ? 0 : 1;
}
