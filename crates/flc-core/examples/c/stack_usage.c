/*
 * Measures the peak stack use of every flc C API function on the host, by stack painting: each
 * call runs on its own 256 KiB stack (ucontext), filled with a pattern beforehand; afterwards the
 * deepest overwritten byte gives the peak. The overhead of the context trampoline (an empty
 * function measured the same way) is subtracted. Prints "stack <function> <bytes>" lines;
 * tests/c_api.rs runs it and checks bounds, docs/firmware.md quotes the figures.
 *
 * Host figures (x86_64); a Cortex-M build differs by its ABI and inlining, so keep a margin.
 */
#define _XOPEN_SOURCE 700
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <ucontext.h>

#include "flc.h"

#define STACK_BYTES (256 * 1024)
static unsigned char stack_mem[STACK_BYTES] __attribute__((aligned(64)));
static ucontext_t main_ctx, fn_ctx;
static void (*current)(void);

static void trampoline(void) { current(); }

static size_t measure(void (*f)(void)) {
    memset(stack_mem, 0xA5, sizeof stack_mem);
    if (getcontext(&fn_ctx) != 0) return 0;
    fn_ctx.uc_stack.ss_sp = stack_mem;
    fn_ctx.uc_stack.ss_size = sizeof stack_mem;
    fn_ctx.uc_link = &main_ctx;
    current = f;
    makecontext(&fn_ctx, trampoline, 0);
    if (swapcontext(&main_ctx, &fn_ctx) != 0) return 0;
    size_t i = 0;
    while (i < sizeof stack_mem && stack_mem[i] == 0xA5) i++;
    return sizeof stack_mem - i;
}

static FlcFallback flc;
static FlcPid pid;
static FlcRobust rob;
static FlcRobust2 rob2;
static FlcRobustParams rob_p;
static FlcRobust2Params rob2_p;
static FlcSupervisor sup;
static FlcPursuit pp;
static FlcDetector det;
static FlcFallbackParams flc_p;
static FlcPidParams pid_p;
static FlcSupervisorParams sup_p;
static FlcPursuitParams pp_p;
static FlcDetectorParams det_p;
static FlcNeighbours nb;
static FlcNeighbourParams nb_p;
static double scan[1800][2];
static size_t scan_n;
static volatile int sink;

static void noop(void) { sink = 0; }
static void fallback_init(void) { sink = flc_fallback_init(&flc, &flc_p, NULL); }
static void fallback_step(void) {
    FlcLongitudinalCommand c;
    sink = flc_fallback_step(&flc, true, 18.0, 10.0, &c);
    sink = flc_fallback_step(&flc, true, 17.5, 10.0, &c);
}
static void robust_init(void) { sink = flc_robust_init(&rob, &rob_p, NULL); }
static void robust_step(void) {
    FlcLongitudinalCommand c;
    sink = flc_robust_step(&rob, true, 18.0, 10.0, &c);
    sink = flc_robust_step(&rob, true, 27.5, 10.0, &c);
}
static void robust2_init(void) { sink = flc_robust2_init(&rob2, &rob2_p, NULL); }
static void robust2_step(void) {
    FlcLongitudinalCommand c;
    sink = flc_robust2_step(&rob2, true, 18.0, 10.0, &c);
    sink = flc_robust2_step(&rob2, true, 27.5, 10.0, &c);
    sink = flc_robust2_step(&rob2, false, 0.0, 10.0, &c);
}
static void pid_init(void) { sink = flc_pid_init(&pid, &pid_p, NULL); }
static void pid_step(void) {
    FlcLongitudinalCommand c;
    sink = flc_pid_step(&pid, 9.0, 10.0, true, 18.0, 0.05, &c);
}
static void supervisor_init(void) { sink = flc_supervisor_init(&sup, &sup_p, NULL); }
static void supervisor_step(void) {
    FlcSupervisorOutput o;
    FlcV2vMessage m = {10.0, 0};
    for (uint32_t k = 1; k < 12; k++) {
        m.seq = k;
        sink = flc_supervisor_step(&sup, true, m, true, 18.0, 10.0, 0.05, &o);
    }
    sink = flc_supervisor_step(&sup, false, m, true, 18.0, 10.0, 0.05, &o);
}
static void supervisor_step_intruder(void) {
    FlcSupervisorOutput o;
    FlcV2vMessage m = {10.0, 0};
    for (uint32_t k = 1; k < 12; k++) {
        m.seq = k;
        sink = flc_supervisor_step_intruder(&sup, true, m, true, 18.0, 10.0, 0.05, k > 8, 9.0, &o);
    }
}
static void pursuit_init(void) { sink = flc_pursuit_init(&pp, &pp_p, NULL); }
static void pursuit_step(void) {
    FlcSteeringCommand s;
    sink = flc_pursuit_step(&pp, true, 20.0, 1.5, 10.0, &s);
}
static void detector_init(void) { sink = flc_detector_init(&det, &det_p, NULL); }
/* Sets a profile, so that the detect below runs with one (its offsets go through it). */
static void detector_set_path_profile(void) {
    static const double bend[5] = {0.0, 0.2, 0.6, 1.2, 2.0};
    sink = flc_detector_set_path_profile(&det, 10.0, bend, 5, NULL);
}
static void detector_detect(void) {
    FlcDetectorOutput o;
    sink = flc_detector_detect(&det, &scan[0][0], scan_n, 0.0, &o);
}

static void neighbours_init(void) { sink = flc_neighbours_init(&nb, &nb_p, NULL); }
static void neighbours_update(void) {
    FlcNeighbourOutput o;
    for (int k = 0; k < 5; k++) sink = flc_neighbours_update(&nb, &det, &o);
}

int main(void) {
    flc_p = flc_fallback_params_default();
    pid_p = flc_pid_params_default();
    rob_p = flc_robust_params_default();
    rob2_p = flc_robust2_params_default();
    sup_p = flc_supervisor_params_default();
    pp_p = flc_pursuit_params_default();
    det_p = flc_detector_params_default();
    nb_p = flc_neighbours_params_default();
    /* A car's rear face at 20 m plus two guard rails and a field of isolated returns (many clusters). */
    size_t n = 0;
    for (int i = 0; i < 300; i++, n++) {
        scan[n][0] = 20.0;
        scan[n][1] = -0.95 + 1.9 * i / 299.0;
    }
    for (int i = 0; i < 600; i++, n++) {
        scan[n][0] = 1.0 + 69.0 * i / 600.0;
        scan[n][1] = (i % 2) ? 5.0 : -5.0;
    }
    for (int i = 0; i < 900; i++, n++) {
        scan[n][0] = 30.0 + 0.8 * (i % 45);
        scan[n][1] = -5.6 + 0.8 * (i / 45 % 15);
    }
    scan_n = n;

    size_t base = measure(noop);
    struct {
        const char *name;
        void (*f)(void);
    } cases[] = {
        {"flc_fallback_init", fallback_init},       {"flc_fallback_step", fallback_step},
        {"flc_robust_init", robust_init},           {"flc_robust_step", robust_step},
        {"flc_robust2_init", robust2_init},         {"flc_robust2_step", robust2_step},
        {"flc_pid_init", pid_init},                 {"flc_pid_step", pid_step},
        {"flc_supervisor_init", supervisor_init},   {"flc_supervisor_step", supervisor_step},
        {"flc_supervisor_step_intruder", supervisor_step_intruder},
        {"flc_pursuit_init", pursuit_init},         {"flc_pursuit_step", pursuit_step},
        {"flc_detector_init", detector_init},
        {"flc_detector_set_path_profile", detector_set_path_profile},
        {"flc_detector_detect", detector_detect},
        {"flc_neighbours_init", neighbours_init},   {"flc_neighbours_update", neighbours_update},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        size_t used = measure(cases[i].f);
        printf("stack %s %zu\n", cases[i].name, used > base ? used - base : 0);
    }
    printf("done\n");
    return 0;
}
