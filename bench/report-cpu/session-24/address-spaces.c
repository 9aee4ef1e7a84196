// K processes on CPU 0 pass a token round a ring, A activations per 100-ms tick in all (the
// first woken by a timer process), each touching P distinct 4-KiB pages per activation. CPU per
// tick of all processes in the steady state (a 14-s run less a 4-s run). The same activations
// shared by more processes: does an activation cost more when more address spaces take turns?
// gcc -O2 -o address-spaces address-spaces.c && ./address-spaces 8 150 3   (A P repeats)
#define _GNU_SOURCE
#include <linux/futex.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>
typedef struct { _Atomic uint32_t word; _Atomic uint32_t waiting; char pad[56]; } bell_t;
static bell_t *bells; static _Atomic int *stop; static _Atomic int *left;
static void ring(int i) { atomic_fetch_add(&bells[i].word, 1); if (atomic_load(&bells[i].waiting)) syscall(SYS_futex, &bells[i].word, FUTEX_WAKE, 1, 0, 0, 0); }
static uint32_t wait_bell(int i, uint32_t seen) {
  for (;;) { uint32_t now = atomic_load(&bells[i].word); if (now != seen || atomic_load(stop)) return now;
    atomic_store(&bells[i].waiting, 1); struct timespec ts = {0, 300000000};
    syscall(SYS_futex, &bells[i].word, FUTEX_WAIT, seen, &ts, 0, 0); atomic_store(&bells[i].waiting, 0); } }
static double run(int K, int A, int P, double seconds) {
  *stop = 0; for (int i = 0; i <= K; i++) bells[i].word = 0;
  pid_t pid = fork();
  if (pid == 0) {
    for (int i = 1; i <= K; i++) if (fork() == 0) {
      char *mem = mmap(0, (size_t)P * 4096 + 4096, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
      memset(mem, 1, (size_t)P * 4096);
      uint32_t seen = 0;
      for (;;) { seen = wait_bell(i, seen); if (atomic_load(stop)) exit(0);
        for (int k = 0; k < P; k++) mem[(size_t)k * 4096]++;
        if (atomic_fetch_sub(left, 1) > 1) ring(i % K + 1); }
    }
    struct timespec next; clock_gettime(CLOCK_MONOTONIC, &next);
    while (!atomic_load(stop)) {
      next.tv_nsec += 100000000; if (next.tv_nsec >= 1000000000) { next.tv_nsec -= 1000000000; next.tv_sec++; }
      clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, 0);
      atomic_store(left, A); ring(1);
    }
    for (int i = 1; i <= K; i++) { atomic_fetch_add(&bells[i].word, 1); syscall(SYS_futex, &bells[i].word, FUTEX_WAKE, 1, 0, 0, 0); }
    while (wait(0) > 0) {}
    exit(0);
  }
  struct timespec s = {(time_t)seconds, 0}; nanosleep(&s, 0); atomic_store(stop, 1);
  struct rusage before, after; getrusage(RUSAGE_CHILDREN, &before); waitpid(pid, 0, 0); getrusage(RUSAGE_CHILDREN, &after);
  return (after.ru_utime.tv_sec - before.ru_utime.tv_sec) + (after.ru_utime.tv_usec - before.ru_utime.tv_usec) * 1e-6
       + (after.ru_stime.tv_sec - before.ru_stime.tv_sec) + (after.ru_stime.tv_usec - before.ru_stime.tv_usec) * 1e-6;
}
int main(int argc, char **argv) {
  int A = atoi(argv[1]), P = atoi(argv[2]), reps = atoi(argv[3]);
  cpu_set_t set; CPU_ZERO(&set); CPU_SET(0, &set); sched_setaffinity(0, sizeof set, &set);
  void *shm = mmap(0, 8192, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  bells = shm; stop = (void *)((char *)shm + 4096); left = (void *)((char *)shm + 4160);
  int Ks[] = {2, 4, 8}; 
  for (int r = 0; r < reps; r++) for (int k = 0; k < 3; k++) {
    int K = Ks[k]; double s = run(K, A, P, 4), l = run(K, A, P, 14);
    printf("K=%d A=%d P=%d  steady %.1f us/tick  %.1f us/activation\n", K, A, P, (l - s) / 100 * 1e6, (l - s) / 100 / A * 1e6);
    fflush(stdout);
  }
}
