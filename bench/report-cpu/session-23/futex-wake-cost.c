// Cost of waking N sleepers: N FUTEX_WAKE calls on N words vs one FUTEX_WAKE on one shared word.
// Each sleeper: FUTEX_WAIT loop on its word. Waker: every 100 ms bumps words and times the wakes
// (the waker's own CPU time around the syscalls, CLOCK_THREAD_CPUTIME_ID, and wall).
#define _GNU_SOURCE
#include <linux/futex.h>
#include <sys/syscall.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <stdio.h>
#include <stdlib.h>
#include <stdint.h>
#include <unistd.h>
#include <time.h>
#include <signal.h>
static long fx(uint32_t *w, int op, uint32_t v) { return syscall(SYS_futex, w, op, v, NULL, NULL, 0); }
static double now(clockid_t c) { struct timespec t; clock_gettime(c, &t); return t.tv_sec * 1e6 + t.tv_nsec / 1e3; }
int main(int argc, char **argv) {
  int n = atoi(argv[1]); int shared = atoi(argv[2]); int rounds = 60;
  uint32_t *words = mmap(NULL, 4096, PROT_READ|PROT_WRITE, MAP_SHARED|MAP_ANONYMOUS, -1, 0);
  pid_t kids[16];
  for (int i = 0; i < n; i++) {
    if ((kids[i] = fork()) == 0) {
      uint32_t *w = shared ? &words[0] : &words[i + 1];
      for (;;) { uint32_t seen = __atomic_load_n(w, __ATOMIC_ACQUIRE); fx(w, FUTEX_WAIT, seen); }
    }
  }
  usleep(200000);
  double cpu_sum = 0, wall_sum = 0; double cpus[100]; 
  struct timespec r0, r1; 
  for (int r = 0; r < rounds; r++) {
    usleep(100000);
    double c0 = now(CLOCK_THREAD_CPUTIME_ID), t0 = now(CLOCK_MONOTONIC);
    if (shared) { __atomic_add_fetch(&words[0], 1, __ATOMIC_RELEASE); fx(&words[0], FUTEX_WAKE, n); }
    else for (int i = 0; i < n; i++) { __atomic_add_fetch(&words[i + 1], 1, __ATOMIC_RELEASE); fx(&words[i + 1], FUTEX_WAKE, 1); }
    double c1 = now(CLOCK_THREAD_CPUTIME_ID), t1 = now(CLOCK_MONOTONIC);
    cpus[r] = c1 - c0; wall_sum += t1 - t0;
  }
  // median
  for (int i = 0; i < rounds; i++) for (int j = i + 1; j < rounds; j++) if (cpus[j] < cpus[i]) { double t = cpus[i]; cpus[i] = cpus[j]; cpus[j] = t; }
  printf("n=%d %s: waker cpu median %.1f us, wall mean %.1f us\n", n, shared ? "one word, one wake" : "n words, n wakes", cpus[rounds/2], wall_sum / rounds);
  for (int i = 0; i < n; i++) kill(kids[i], SIGKILL);
  while (wait(NULL) > 0);
  return 0;
}
