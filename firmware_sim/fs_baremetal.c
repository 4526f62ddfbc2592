/* fs_baremetal.c -- the bare-metal platform of closed_loop.c on an Arm Cortex-M (QEMU mps2 boards, or a real part
 * with a semihosting debugger): vector table, reset handler, SysTick clock and the command line from semihosting.
 *
 * Reset: copy .data from flash, zero .bss and the harness's buffers (.bss.fs_harness, external RAM), give the FPU
 * full access (CPACR), open newlib's semihosting file handles, split the semihosting command line (SYS_GET_CMDLINE)
 * into argv, call main and exit with its return code (newlib's exit -> SYS_EXIT_EXTENDED, so QEMU returns the code).
 * A fault prints one line and exits with code 70.
 * Clock: SysTick on the processor clock (FS_SYSTICK_HZ, the board's, from fcgen's target table), free-running, its
 * 24-bit count extended to 32 bits (modulo 2^32) on every read: fs_clock gives the solver integer ticks, no floating
 * point; under `qemu -icount shift=0` one instruction takes 1 ns, so ticks * 1e9 / FS_SYSTICK_HZ is an instruction
 * count (with the tick's granularity). Link with the linker script rendered by fcgen
 * (templates/targets/cortexm.ld.j2), --specs=rdimon.specs -nostartfiles. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#ifndef FS_BAREMETAL
#define FS_BAREMETAL /* this file is the bare-metal platform (fs_platform.h's branch) */
#endif
#include "fs_platform.h"

extern uint32_t __data_load__, __data_start__, __data_end__, __bss_start__, __bss_end__, __stack_top__;
extern uint32_t __fs_harness_start__, __fs_harness_end__;
extern int main(int argc, char **argv);
extern void initialise_monitor_handles(void);
void Reset_Handler(void);
void _init(void);
void _fini(void);

#define SCB_CPACR (*(volatile uint32_t *)0xE000ED88u)
#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)
#define SH_WRITE0 0x04
#define SH_GET_CMDLINE 0x15
#define SH_EXIT_EXTENDED 0x20
#define FS_MAX_ARGS 8

static int sh_call(int op, void *arg) {
  register int r0 __asm__("r0") = op;
  register void *r1 __asm__("r1") = arg;
  __asm__ volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
  return r0;
}

/* ------------------------------------------------------------------------------------------------ clock */
static uint32_t g_ticks;
static uint32_t g_last;

static void clock_start(void) {
  SYST_RVR = 0x00FFFFFFu;
  SYST_CVR = 0u;
  SYST_CSR = 5u; /* enable, processor clock, no interrupt */
  g_last = SYST_CVR;
}

uint32_t fs_clock(void) {
  uint32_t now = SYST_CVR;
  g_ticks += (g_last - now) & 0x00FFFFFFu; /* down-counter; read at least once per 2^24 ticks */
  g_last = now;
  return g_ticks;
}

/* ------------------------------------------------------------------------------------------------ startup */
static char g_cmdline[512];
static char *g_argv[FS_MAX_ARGS + 1];

static int split_cmdline(void) {
  struct {
    char *buf;
    int len;
  } blk = {g_cmdline, (int)sizeof g_cmdline - 1};
  int argc = 0;
  char *p;
  if (sh_call(SH_GET_CMDLINE, &blk) != 0) blk.len = 0;
  g_cmdline[blk.len] = '\0';
  for (p = strtok(g_cmdline, " "); p != NULL && argc < FS_MAX_ARGS; p = strtok(NULL, " ")) g_argv[argc++] = p;
  g_argv[argc] = NULL;
  return argc;
}

void Reset_Handler(void) {
  const uint32_t *src = &__data_load__;
  uint32_t *dst;
  for (dst = &__data_start__; dst < &__data_end__;) *dst++ = *src++;
  for (dst = &__bss_start__; dst < &__bss_end__;) *dst++ = 0u;
  for (dst = &__fs_harness_start__; dst < &__fs_harness_end__;) *dst++ = 0u;
  SCB_CPACR |= 0xFu << 20; /* CP10, CP11: full access */
  __asm__ volatile("dsb\n\tisb" ::: "memory");
  initialise_monitor_handles();
  clock_start();
  exit(main(split_cmdline(), g_argv));
}

static void Fault_Handler(void) {
  uint32_t block[2] = {0x20026u, 70u}; /* ADP_Stopped_ApplicationExit, code 70 */
  sh_call(SH_WRITE0, "closed_loop: CPU fault (HardFault/MemManage/BusFault/UsageFault)\n");
  sh_call(SH_EXIT_EXTENDED, block);
  for (;;) {
  }
}

/* newlib's exit() calls _fini (no C++ constructors/destructors here) */
void _init(void) {
}
void _fini(void) {
}

__attribute__((section(".vectors"), used)) static const uintptr_t g_vectors[16] = {(uintptr_t)&__stack_top__,
                                                                                   (uintptr_t)Reset_Handler,
                                                                                   (uintptr_t)Fault_Handler,
                                                                                   (uintptr_t)Fault_Handler,
                                                                                   (uintptr_t)Fault_Handler,
                                                                                   (uintptr_t)Fault_Handler,
                                                                                   (uintptr_t)Fault_Handler,
                                                                                   0u,
                                                                                   0u,
                                                                                   0u,
                                                                                   0u,
                                                                                   (uintptr_t)Fault_Handler,
                                                                                   (uintptr_t)Fault_Handler,
                                                                                   0u,
                                                                                   (uintptr_t)Fault_Handler,
                                                                                   (uintptr_t)Fault_Handler};

/* ------------------------------------------------------------------------------------------------ probe ticks */
/* fs_platform.h: the SysTick count itself (FS_SYSTICK_HZ a second, modulo 2^32), the one fs_clock accumulates. */
uint32_t fs_ticks(void) {
  const uint32_t now = SYST_CVR;
  g_ticks += (g_last - now) & 0x00FFFFFFu; /* down-counter; read at least once per 2^24 ticks */
  g_last = now;
  return (uint32_t)g_ticks;
}
