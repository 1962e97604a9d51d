/*
 * tick_insns: a QEMU TCG plugin that counts the guest instructions retired between two marker
 * functions of the firmware, `insn_mark_start` and `insn_mark_end`, and prints one line
 *
 *     tick-insns <count>
 *
 * per start/end pair to QEMU's log (`-d plugin -D FILE`). `beam pil` brackets each call of
 * `Drive::tick` in the PIL firmware with the markers, so every tick gets its exact, repeatable
 * cost in instructions (QEMU does not model the Cortex-M cycle counter).
 *
 * How: every translated instruction gets an inline "add 1" on a 64-bit counter; the first
 * instruction of each marker function also gets a callback, which runs before that
 * instruction's add. The start callback remembers the counter and the end callback prints
 * the difference, so a window counts the start marker's body, everything called between the
 * markers, and the call of the end marker, but not the end marker's body.
 *
 * With the argument `profile=on` (`-plugin libtick_insns.so,profile=on`) it also counts, per
 * instruction address, how often each instruction ran inside a window, and prints
 * `tick-insns-at 0xADDR N` lines at exit; `profile.py` turns them into a table by (inlined)
 * function with the firmware's debug information. Profiling registers a callback on every
 * instruction and runs several times slower; the per-tick lines are the same either way.
 *
 * With `profile=worst` the per-address counts are those of one window only: the first with
 * the most instructions (the tick a budget is about), preceded by `tick-insns-profile worst
 * <count>`.
 *
 * The per-address counts of a window exceed its `tick-insns` count by the same few
 * instructions in every window: on QEMU 7.2, the start marker's body after its first
 * instruction (5 for the PIL firmware), which the callbacks count and the inline counter,
 * read by the start marker's callback, does not. `beam-tools/tests/pil.rs` checks that the
 * difference is the same in every window.
 *
 * Written against QEMU's plugin API version 1 (Debian bookworm's qemu-system-arm 7.2). Debian
 * ships no qemu-plugin.h, so the few declarations used are written out below, as QEMU's
 * include/qemu/qemu-plugin.h defines them for that version.
 */
#include <inttypes.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- the part of QEMU's plugin API this plugin uses (API version 1) ---- */
typedef uint64_t qemu_plugin_id_t;
typedef struct qemu_info_t qemu_info_t;
struct qemu_plugin_tb;
struct qemu_plugin_insn;
enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS, QEMU_PLUGIN_CB_R_REGS, QEMU_PLUGIN_CB_RW_REGS };
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
typedef void (*tb_trans_cb)(qemu_plugin_id_t id, struct qemu_plugin_tb *tb);
typedef void (*vcpu_udata_cb)(unsigned int vcpu_index, void *userdata);
typedef void (*atexit_cb)(qemu_plugin_id_t id, void *userdata);
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, tb_trans_cb cb);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
struct qemu_plugin_insn *qemu_plugin_tb_get_insn(const struct qemu_plugin_tb *tb, size_t idx);
const char *qemu_plugin_insn_symbol(const struct qemu_plugin_insn *insn);
uint64_t qemu_plugin_insn_vaddr(const struct qemu_plugin_insn *insn);
void qemu_plugin_register_vcpu_insn_exec_cb(struct qemu_plugin_insn *insn, vcpu_udata_cb cb,
                                            enum qemu_plugin_cb_flags flags, void *userdata);
void qemu_plugin_register_vcpu_insn_exec_inline(struct qemu_plugin_insn *insn,
                                                enum qemu_plugin_op op, void *ptr, uint64_t imm);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, atexit_cb cb, void *userdata);
void qemu_plugin_outs(const char *string);
/* ----------------------------------------------------------------------- */

__attribute__((visibility("default"))) int qemu_plugin_version = 1;

/* One emulated core (the Cortex-M4), so plain globals are enough. */
static uint64_t retired;     /* instructions retired so far */
static uint64_t window_start; /* `retired` when the start marker ran */
static bool in_window;

/* Profiling: executions per instruction address inside windows, for flash at 0x0800_0000
 * (Thumb instructions are 2-byte aligned; 2 MiB covers the STM32F405's 1 MiB of flash). */
#define FLASH_BASE 0x08000000u
#define PROFILE_SLOTS (1u << 20)
static bool profiling;
static uint64_t *profile;

/* `profile=worst`: this window's counts, the slots it touched (to clear them after), and the
 * largest window so far, whose counts `profile` holds. */
#define MAX_TOUCHED (1u << 16)
static bool worst_only;
static uint64_t *window_counts;
static uint32_t *touched;
static size_t n_touched;
static bool touched_overflow;
static uint64_t worst_insns;
static bool have_worst;

static void on_insn(unsigned int vcpu, void *userdata) {
    (void)vcpu;
    if (!in_window) {
        return;
    }
    uintptr_t slot = (uintptr_t)userdata;
    if (!worst_only) {
        profile[slot]++;
    } else if (window_counts[slot]++ == 0) {
        if (n_touched < MAX_TOUCHED) {
            touched[n_touched++] = (uint32_t)slot;
        } else {
            touched_overflow = true;
        }
    }
}

/* End of a window in `profile=worst`: keep its counts if it is the largest so far, then
 * clear them for the next. */
static void end_worst_window(uint64_t insns) {
    if (touched_overflow) {
        /* More distinct instructions than the list holds: keep nothing of it, clear all. */
        memset(window_counts, 0, PROFILE_SLOTS * sizeof *window_counts);
        touched_overflow = false;
        n_touched = 0;
        qemu_plugin_outs("tick-insns-profile: a window too large to profile\n");
        return;
    }
    if (!have_worst || insns > worst_insns) {
        have_worst = true;
        worst_insns = insns;
        memset(profile, 0, PROFILE_SLOTS * sizeof *profile);
        for (size_t i = 0; i < n_touched; i++) {
            profile[touched[i]] = window_counts[touched[i]];
        }
    }
    for (size_t i = 0; i < n_touched; i++) {
        window_counts[touched[i]] = 0;
    }
    n_touched = 0;
}

static void print_profile(qemu_plugin_id_t id, void *userdata) {
    (void)id;
    (void)userdata;
    char line[64];
    if (worst_only) {
        snprintf(line, sizeof line, "tick-insns-profile worst %" PRIu64 "\n", worst_insns);
        qemu_plugin_outs(line);
    }
    for (size_t i = 0; i < PROFILE_SLOTS; i++) {
        if (profile[i] != 0) {
            snprintf(line, sizeof line, "tick-insns-at 0x%08zx %" PRIu64 "\n",
                     (size_t)FLASH_BASE + 2 * i, profile[i]);
            qemu_plugin_outs(line);
        }
    }
}

static void on_mark_start(unsigned int vcpu, void *userdata) {
    (void)vcpu;
    (void)userdata;
    window_start = retired;
    in_window = true;
}

static void on_mark_end(unsigned int vcpu, void *userdata) {
    (void)vcpu;
    (void)userdata;
    if (!in_window) {
        return; /* an end without a start: nothing to report */
    }
    in_window = false;
    char line[48];
    snprintf(line, sizeof line, "tick-insns %" PRIu64 "\n", retired - window_start);
    qemu_plugin_outs(line);
    if (worst_only) {
        end_worst_window(retired - window_start);
    }
}

/* True when `insn` is the first instruction of the function named `name`. QEMU reports the
 * symbol only for an instruction at a symbol's address. */
static bool starts(const struct qemu_plugin_insn *insn, const char *name) {
    const char *sym = qemu_plugin_insn_symbol(insn);
    return sym != NULL && strcmp(sym, name) == 0;
}

static void on_translate(qemu_plugin_id_t id, struct qemu_plugin_tb *tb) {
    (void)id;
    size_t n = qemu_plugin_tb_n_insns(tb);
    for (size_t i = 0; i < n; i++) {
        struct qemu_plugin_insn *insn = qemu_plugin_tb_get_insn(tb, i);
        if (starts(insn, "insn_mark_start")) {
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_mark_start, QEMU_PLUGIN_CB_NO_REGS, NULL);
        } else if (starts(insn, "insn_mark_end")) {
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_mark_end, QEMU_PLUGIN_CB_NO_REGS, NULL);
        }
        qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64, &retired, 1);
        uint64_t slot = (qemu_plugin_insn_vaddr(insn) - FLASH_BASE) / 2;
        if (profiling && slot < PROFILE_SLOTS) {
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_insn, QEMU_PLUGIN_CB_NO_REGS,
                                                   (void *)(uintptr_t)slot);
        }
    }
}

__attribute__((visibility("default"))) int qemu_plugin_install(qemu_plugin_id_t id,
                                                                const qemu_info_t *info,
                                                                int argc, char **argv) {
    (void)info;
    for (int i = 0; i < argc; i++) {
        if (strcmp(argv[i], "profile=on") == 0) {
            profiling = true;
        } else if (strcmp(argv[i], "profile=worst") == 0) {
            profiling = true;
            worst_only = true;
        } else {
            fprintf(stderr, "tick_insns: unknown argument `%s` (expected profile=on or profile=worst)\n",
                    argv[i]);
            return -1;
        }
    }
    if (profiling) {
        profile = calloc(PROFILE_SLOTS, sizeof *profile);
        if (profile == NULL) {
            return -1;
        }
        if (worst_only) {
            window_counts = calloc(PROFILE_SLOTS, sizeof *window_counts);
            touched = calloc(MAX_TOUCHED, sizeof *touched);
            if (window_counts == NULL || touched == NULL) {
                return -1;
            }
        }
        qemu_plugin_register_atexit_cb(id, print_profile, NULL);
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_translate);
    return 0;
}
