#define _GNU_SOURCE
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>
#include <time.h>
#include <fcntl.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/syscall.h>
#include <linux/futex.h>
#include <stdatomic.h>
#include <sys/wait.h>
// ring_chain N ROUNDS PAGES: N processes in a chain (run it under `taskset -c 1` for one CPU):
// process 0 sleeps 10 ms (a timer wake-up), then rings process 1 (FUTEX_WAKE), which rings 2, and
// so on; the last rings process 0 too, which is asleep on its timer, so that ring finds no waiter.
// Each process reads one byte in each of PAGES pages of its own memory per wake-up. Prints the CPU
// per hop: every process's own CPU clock over ROUNDS rounds, summed, / (ROUNDS * N).
static double cpu(){struct timespec t;clock_gettime(CLOCK_PROCESS_CPUTIME_ID,&t);return t.tv_sec*1e9+t.tv_nsec;}
int main(int argc,char**argv){
  int n=atoi(argv[1]), rounds=atoi(argv[2]), pages=atoi(argv[3]);
  _Atomic unsigned *w=mmap(0,4096*64,PROT_READ|PROT_WRITE,MAP_SHARED|MAP_ANONYMOUS,-1,0);
  double *res=(double*)(w+4096);
  for(int i=0;i<n;i++){
    if(fork()==0){
      char*mem=malloc(pages*4096+1); for(int k=0;k<pages;k++) mem[k*4096]=1;
      _Atomic unsigned *mine=w+i*16, *next=w+((i+1)%n)*16; unsigned seen=0; volatile long s=0;
      double c0=cpu();
      for(int r=0;r<rounds;r++){
        if(i==0){ struct timespec t={0,10000000}; nanosleep(&t,0);} else { while(*mine==seen) syscall(SYS_futex,mine,FUTEX_WAIT,seen,0,0,0); seen=*mine; }
        for(int k=0;k<pages;k++) s+=mem[k*4096];
        { atomic_fetch_add(next,1); syscall(SYS_futex,next,FUTEX_WAKE,1,0,0,0); }
      }
      res[i]=cpu()-c0; _exit(0);
    }
  }
  while(wait(0)>0);
  double tot=0; for(int i=0;i<n;i++) tot+=res[i];
  printf("n=%d pages=%d: CPU per hop %.1f us\n",n,pages,tot/rounds/n/1e3);
}
