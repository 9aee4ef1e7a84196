// What the two probes share: a doorbell per process (a futex word in shared memory, rung only
// when its process sleeps on it, as the bus's doorbells are), the pages an activation touches,
// the 100-ms tick, CPU 0 and the CPU time of the children. Include after `#define _GNU_SOURCE`.
#include <linux/futex.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

typedef struct { _Atomic uint32_t word; _Atomic uint32_t waiting; char pad[56]; } bell_t;
static bell_t *bells;
static _Atomic int *stop;

static void ring(int i) {
  atomic_fetch_add(&bells[i].word, 1);
  if (atomic_load(&bells[i].waiting)) syscall(SYS_futex, &bells[i].word, FUTEX_WAKE, 1, 0, 0, 0);
}

// Sleeps until bell i has rung past `seen` (or the run stops); the bell's count then.
static uint32_t wait_bell(int i, uint32_t seen) {
  for (;;) {
    uint32_t now = atomic_load(&bells[i].word);
    if (now != seen || atomic_load(stop)) return now;
    atomic_store(&bells[i].waiting, 1);
    struct timespec timeout = {0, 300000000};
    syscall(SYS_futex, &bells[i].word, FUTEX_WAIT, seen, &timeout, 0, 0);
    atomic_store(&bells[i].waiting, 0);
  }
}

// `pages` private pages, written once so that they are mapped.
static char *pages_of_own(int pages) {
  if (!pages) return 0;
  char *mem = mmap(0, (size_t)pages * 4096, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  memset(mem, 1, (size_t)pages * 4096);
  return mem;
}

// One byte of each page: what an activation's own memory costs.
static void touch(char *mem, int pages) {
  for (int k = 0; k < pages; k++) mem[(size_t)k * 4096]++;
}

// Pins the calling process (and the children it forks afterwards) to CPU 0.
static void pin_to_cpu0(void) {
  cpu_set_t cpu0;
  CPU_ZERO(&cpu0);
  CPU_SET(0, &cpu0);
  sched_setaffinity(0, sizeof cpu0, &cpu0);
}

// `bytes` of memory shared with the children forked afterwards.
static char *shared_memory(size_t bytes) {
  return mmap(0, bytes, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
}

// Sleeps until `next` advanced by one 100-ms tick (absolute, so ticks do not drift).
static void sleep_to_next_tick(struct timespec *next) {
  next->tv_nsec += 100000000;
  if (next->tv_nsec >= 1000000000) { next->tv_nsec -= 1000000000; next->tv_sec++; }
  clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, next, 0);
}

// CPU (user + system) of the reaped children so far, s.
static double children_cpu_s(void) {
  struct rusage u;
  getrusage(RUSAGE_CHILDREN, &u);
  return u.ru_utime.tv_sec + u.ru_utime.tv_usec * 1e-6 + u.ru_stime.tv_sec + u.ru_stime.tv_usec * 1e-6;
}
