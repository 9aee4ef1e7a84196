// futex_ring N [batch]: one process sleeps on a futex word in /dev/shm, another wakes it every
// 100 ms with FUTEX_WAKE; prints the ringer's CPU (thread CPU clock) per FUTEX_WAKE call. With a
// second argument the waiter runs SCHED_BATCH (no wake-up preemption).
#define _GNU_SOURCE
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>
#include <time.h>
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/syscall.h>
#include <linux/futex.h>
#include <stdatomic.h>
#include <sys/wait.h>
#include <sys/resource.h>
#include <sched.h>
static double now(){struct timespec t;clock_gettime(CLOCK_MONOTONIC,&t);return t.tv_sec*1e9+t.tv_nsec;}
static double cpu(){struct timespec t;clock_gettime(CLOCK_THREAD_CPUTIME_ID,&t);return t.tv_sec*1e9+t.tv_nsec;}
int main(int argc,char**argv){
  int n=atoi(argv[1]);
  int fd=open("/dev/shm/fwtest",O_CREAT|O_RDWR,0600); ftruncate(fd,4096);
  _Atomic unsigned *w=mmap(0,4096,PROT_READ|PROT_WRITE,MAP_SHARED,fd,0);
  *w=0;
  pid_t c=fork();
  if(c==0){ if(argc>2){struct sched_param sp={0}; sched_setscheduler(0,SCHED_BATCH,&sp);} unsigned seen=0; for(int i=0;i<n;i++){ while(*w==seen) syscall(SYS_futex,w,FUTEX_WAIT,seen,0,0,0); seen=*w;} return 0;}
  double total=0; 
  for(int i=0;i<n;i++){ struct timespec s={0,100000000}; nanosleep(&s,0); usleep(0);
    double c0=cpu(); atomic_fetch_add(w,1); syscall(SYS_futex,w,FUTEX_WAKE,1,0,0,0); total+=cpu()-c0; }
  waitpid(c,0,0);
  printf("ringer cpu per wake (wake syscall only) %.1f us\n", total/n/1e3);
}
