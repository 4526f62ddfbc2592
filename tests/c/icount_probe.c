/* icount_probe.c -- the bare-metal clock hook (fs_baremetal.c) against a loop of a known instruction count:
 * `subs; bne` x N = 2 N instructions. Prints N and the measured instruction count (ticks x 1e9 / FS_TICKS_PER_SECOND,
 * QEMU -icount shift=0). */
#include <stdio.h>

#include "fs_platform.h"

int main(void) {
  unsigned n = 1000000u;
  const unsigned n0 = n;
  uint32_t t0, t1;
  t0 = fs_clock();
  __asm__ volatile("1: subs %0, %0, #1\n\tbne 1b" : "+r"(n) : : "cc");
  t1 = fs_clock();
  printf("%u %.0f\n", n0, (double)(uint32_t)(t1 - t0) * (1e9 / (double)FS_TICKS_PER_SECOND));
  return 0;
}
