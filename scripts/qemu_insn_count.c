// A qemu-user TCG plugin that counts the guest instructions executed (instructions per frame on
// aarch64 without hardware counters; BENCHMARKS.md "Instructions per frame").
// Debian 12's qemu-user (7.2) is built with plugin support but ships neither the plugins nor
// qemu-plugin.h, so the few declarations of the plugin API (version 1, QEMU 7.2's
// include/qemu/qemu-plugin.h) it uses are written out here.
// Counting: at translation each block gets an inline "add its instruction count to a 64-bit
// counter" op, run every time the block executes (so a block left early by an exception counts
// in full; single-threaded guests only: the add is not atomic).
// With `by_symbol=on` it also writes one line per function of the main executable ("count
// symbol", symbol as qemu resolves it from the ELF symbol table: mangled C++ names; blocks in
// shared libraries count under "?"), attributing each block to the function of its first
// instruction: exclusive (self) counts, to add up per module.
// Build: gcc -shared -fPIC -O2 -o build-aarch64/libinsn_count.so scripts/qemu_insn_count.c
// Use:   qemu-aarch64 -plugin build-aarch64/libinsn_count.so,out=FILE prog...   (out= optional:
//        without it the count goes to qemu's plugin log, stderr; by_symbol=on needs out=)
#include <inttypes.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

typedef uint64_t qemu_plugin_id_t;
struct qemu_plugin_tb;
typedef struct qemu_info_t qemu_info_t;
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
typedef void (*qemu_plugin_vcpu_tb_trans_cb_t)(qemu_plugin_id_t id, struct qemu_plugin_tb* tb);
typedef void (*qemu_plugin_udata_cb_t)(qemu_plugin_id_t id, void* userdata);
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, qemu_plugin_vcpu_tb_trans_cb_t cb);
void qemu_plugin_register_vcpu_tb_exec_inline(struct qemu_plugin_tb* tb, enum qemu_plugin_op op,
                                              void* ptr, uint64_t imm);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb* tb);
struct qemu_plugin_insn;
struct qemu_plugin_insn* qemu_plugin_tb_get_insn(const struct qemu_plugin_tb* tb, size_t idx);
const char* qemu_plugin_insn_symbol(const struct qemu_plugin_insn* insn);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, qemu_plugin_udata_cb_t cb, void* userdata);
void qemu_plugin_outs(const char* string);

__attribute__((visibility("default"))) int qemu_plugin_version = 1;

static uint64_t insn_count;
static char out_path[4096];
static int by_symbol;

// Per-symbol counters: an open-addressing table keyed by the symbol's address (qemu returns the
// same pointer for a symbol every time), filled at translation (not on the execution path).
enum { kTableSize = 1 << 16 };
static struct {
  const char* name;
  uint64_t count;
} table[kTableSize];

static uint64_t* SymbolCounter(const char* name) {
  size_t h = ((uintptr_t)name >> 3) & (kTableSize - 1);
  for (size_t probe = 0; probe < kTableSize; ++probe, h = (h + 1) & (kTableSize - 1)) {
    if (table[h].name == name) return &table[h].count;
    if (table[h].name == NULL) {
      table[h].name = name;
      return &table[h].count;
    }
  }
  return NULL;  // table full: the block still counts in the total
}

static void OnTranslate(qemu_plugin_id_t id, struct qemu_plugin_tb* tb) {
  (void)id;
  const size_t n = qemu_plugin_tb_n_insns(tb);
  qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &insn_count, n);
  if (by_symbol && n > 0) {
    const char* sym = qemu_plugin_insn_symbol(qemu_plugin_tb_get_insn(tb, 0));
    uint64_t* counter = SymbolCounter(sym ? sym : "?");
    if (counter) qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, counter, n);
  }
}

static void OnExit(qemu_plugin_id_t id, void* userdata) {
  (void)id;
  (void)userdata;
  char line[64];
  snprintf(line, sizeof line, "insns %" PRIu64 "\n", insn_count);
  FILE* f = out_path[0] ? fopen(out_path, "w") : NULL;
  if (f) {
    fputs(line, f);
    for (size_t i = 0; by_symbol && i < kTableSize; ++i) {
      if (table[i].name && table[i].count) fprintf(f, "%" PRIu64 " %s\n", table[i].count, table[i].name);
    }
    fclose(f);
  } else {
    qemu_plugin_outs(line);
  }
}

__attribute__((visibility("default"))) int qemu_plugin_install(qemu_plugin_id_t id,
                                                               const qemu_info_t* info, int argc,
                                                               char** argv) {
  (void)info;
  for (int i = 0; i < argc; ++i) {
    if (strncmp(argv[i], "out=", 4) == 0) {
      snprintf(out_path, sizeof out_path, "%s", argv[i] + 4);
    } else if (strcmp(argv[i], "by_symbol=on") == 0) {
      by_symbol = 1;
    } else {
      fprintf(stderr, "qemu_insn_count: unknown argument '%s' (out=FILE, by_symbol=on)\n", argv[i]);
      return -1;
    }
  }
  qemu_plugin_register_vcpu_tb_trans_cb(id, OnTranslate);
  qemu_plugin_register_atexit_cb(id, OnExit, NULL);
  return 0;
}
