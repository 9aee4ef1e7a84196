// syscall: a system call (getppid) warm, in a loop, and once after each 100-ms sleep; the vDSO
// clock read for comparison.
#define _GNU_SOURCE
#include <stdio.h>
#include <time.h>
#include <unistd.h>
#include <sys/syscall.h>
static double now(){struct timespec t;clock_gettime(CLOCK_MONOTONIC,&t);return t.tv_sec*1e9+t.tv_nsec;}
int main(){ int n=200000; double t0=now(); for(int i=0;i<n;i++) syscall(SYS_getppid); double t1=now();
 printf("getppid %.0f ns\n",(t1-t0)/n);
 t0=now(); for(int i=0;i<n;i++){struct timespec t;clock_gettime(CLOCK_MONOTONIC,&t);} t1=now(); printf("clock_gettime vdso %.0f ns\n",(t1-t0)/n);
 double d=0; for(int i=0;i<50;i++){ usleep(100000); double a=now(); syscall(SYS_getppid); d+=now()-a;} printf("cold getppid after 100ms sleep %.0f ns\n",d/50);
}
