// K processes on CPU 0 pass a token round a ring, A activations per 100-ms tick in all (the
// first woken by a timer process), each touching P distinct 4-KiB pages per activation. CPU per
// tick of all processes in the steady state (a 14-s run less a 4-s run). The same activations
// shared by more processes: does an activation cost more when more address spaces take turns?
// gcc -O2 -o address-spaces address-spaces.c && ./address-spaces 8 150 3   (A P repeats)
#define _GNU_SOURCE
#include <stdio.h>
#include <sys/wait.h>
#include "probe.h"

static _Atomic int *left; /* activations still to come in this tick */

// Ring process i of K: each activation touches its pages and passes the token on.
static void member(int i, int K, int P) {
  char *mem = pages_of_own(P);
  uint32_t seen = 0;
  for (;;) {
    seen = wait_bell(i, seen);
    if (atomic_load(stop)) exit(0);
    touch(mem, P);
    if (atomic_fetch_sub(left, 1) > 1) ring(i % K + 1);
  }
}

// CPU (user + system) of a run of `seconds` with K processes, the timer process included.
static double run(int K, int A, int P, int seconds) {
  *stop = 0;
  for (int i = 0; i <= K; i++) bells[i].word = 0;
  pid_t pid = fork();
  if (pid == 0) {
    for (int i = 1; i <= K; i++)
      if (fork() == 0) member(i, K, P);
    struct timespec next;
    clock_gettime(CLOCK_MONOTONIC, &next);
    while (!atomic_load(stop)) {
      sleep_to_next_tick(&next);
      atomic_store(left, A);
      ring(1);
    }
    for (int i = 1; i <= K; i++) ring(i);
    while (wait(0) > 0) {}
    exit(0);
  }
  sleep(seconds);
  atomic_store(stop, 1);
  double before = children_cpu_s();
  waitpid(pid, 0, 0);
  return children_cpu_s() - before;
}

int main(int argc, char **argv) {
  if (argc != 4) {
    fprintf(stderr, "usage: %s ACTIVATIONS_PER_TICK PAGES REPEATS\n", argv[0]);
    return 2;
  }
  int A = atoi(argv[1]), P = atoi(argv[2]), reps = atoi(argv[3]);
  pin_to_cpu0();
  char *shared = shared_memory(8192);
  bells = (bell_t *)shared;
  stop = (_Atomic int *)(shared + 4096);
  left = (_Atomic int *)(shared + 4160);
  const int Ks[] = {2, 4, 8};
  for (int r = 0; r < reps; r++)
    for (int k = 0; k < 3; k++) {
      int K = Ks[k];
      double s = run(K, A, P, 4), l = run(K, A, P, 14);
      printf("K=%d A=%d P=%d  steady %.1f us/tick  %.1f us/activation\n", K, A, P, (l - s) / 100 * 1e6,
             (l - s) / 100 / A * 1e6);
      fflush(stdout);
    }
}
