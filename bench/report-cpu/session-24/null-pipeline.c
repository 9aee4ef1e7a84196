// A null pipeline: processes that do nothing but wake each other through futex words in shared
// memory, in the activation pattern of the paced pipeline's tick, all on CPU 0, each touching
// PAGES distinct 4-KiB pages per activation. Prints the CPU (user + system) of all of them per
// second of run: what the process split alone costs on this host, before any code of ours.
//
//   split:   the plant's timer wakes gyro, wheels and CMG gateways every tick and the
//            inclinometer and magnetometer gateways every 4th; the sensor gateways ring the
//            estimator, the estimator rings the controller (profile `simulation`, 8 processes)
//   grouped: the plant wakes one gateway process, which rings the estimator, which rings the
//            controller (profile `simulation-grouped`, 4 processes)
//   timer:   the plant's timer alone
//
// gcc -O2 -o null-pipeline null-pipeline.c && ./null-pipeline split 30 150
#define _GNU_SOURCE
#include <stdio.h>
#include <sys/wait.h>
#include "probe.h"

enum { PLANT, GYRO, WHEELS, CMG, TILT, FIELD, ESTIMATOR, CONTROLLER, N };
static int rings[N]; /* bit mask of the processes each one rings after an activation */

static void process(int i, int pages) {
  char *mem = pages_of_own(pages);
  uint32_t seen = 0;
  for (;;) {
    seen = wait_bell(i, seen);
    if (atomic_load(stop)) exit(0);
    touch(mem, pages);
    for (int t = 0; t < N; t++)
      if (rings[i] & (1 << t)) ring(t);
  }
}

int main(int argc, char **argv) {
  const char *pattern = argc > 1 ? argv[1] : "split";
  int seconds = argc > 2 ? atoi(argv[2]) : 30;
  int pages = argc > 3 ? atoi(argv[3]) : 0;
  pin_to_cpu0();
  char *shared = shared_memory(4096);
  bells = (bell_t *)shared;
  stop = (_Atomic int *)(shared + 2048);
  int every_tick = 0, every_4th = 0, started = 0;
  if (!strcmp(pattern, "split")) {
    every_tick = 1 << GYRO | 1 << WHEELS | 1 << CMG;
    every_4th = 1 << TILT | 1 << FIELD;
    rings[GYRO] = rings[TILT] = rings[FIELD] = 1 << ESTIMATOR;
    rings[ESTIMATOR] = 1 << CONTROLLER;
    started = every_tick | every_4th | 1 << ESTIMATOR | 1 << CONTROLLER;
  } else if (!strcmp(pattern, "grouped")) {
    every_tick = 1 << GYRO;
    rings[GYRO] = 1 << ESTIMATOR;
    rings[ESTIMATOR] = 1 << CONTROLLER;
    started = every_tick | 1 << ESTIMATOR | 1 << CONTROLLER;
  } else if (strcmp(pattern, "timer")) {
    fprintf(stderr, "pattern must be split, grouped or timer, not %s\n", pattern);
    return 2;
  }
  for (int i = 1; i < N; i++)
    if (started & (1 << i) && fork() == 0) process(i, pages);
  if (fork() == 0) {
    char *mem = pages_of_own(pages);
    struct timespec next;
    clock_gettime(CLOCK_MONOTONIC, &next);
    for (unsigned tick = 0; !atomic_load(stop); tick++) {
      sleep_to_next_tick(&next);
      touch(mem, pages);
      int mask = every_tick | (tick % 4 == 0 ? every_4th : 0);
      for (int t = 0; t < N; t++)
        if (mask & (1 << t)) ring(t);
    }
    exit(0);
  }
  sleep(seconds);
  atomic_store(stop, 1);
  for (int i = 0; i < N; i++) ring(i);
  while (wait(0) > 0) {}
  double cpu = children_cpu_s();
  printf("%-7s pages=%-4d %d s: %.3f %% of one core, %.1f us a tick\n", pattern, pages, seconds,
         100 * cpu / seconds, cpu / (seconds * 10.0) * 1e6);
  return 0;
}
