// pages N HUGE STRIDE: after each of 60 sleeps of 100 ms, read one byte at N places STRIDE bytes
// apart in a 64-MiB anonymous mapping (HUGE=1: transparent huge pages, 0: 4-KiB pages); prints
// the median time of the N reads.
#define _GNU_SOURCE
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <sys/mman.h>
#include <stdint.h>
static double now(){struct timespec t;clock_gettime(CLOCK_MONOTONIC,&t);return t.tv_sec*1e9+t.tv_nsec;}
int cmp(const void*a,const void*b){double x=*(double*)a,y=*(double*)b;return x<y?-1:x>y;}
int main(int argc,char**argv){
  int npages=atoi(argv[1]); int huge=atoi(argv[2]); int stride=atoi(argv[3]); // stride bytes between touches
  size_t len=64UL<<20;
  char*raw=mmap(0,len+(2<<20),PROT_READ|PROT_WRITE,MAP_PRIVATE|MAP_ANONYMOUS,-1,0);
  char*p=(char*)(((uintptr_t)raw+(2<<20)-1)&~((uintptr_t)(2<<20)-1));
  madvise(p,len,huge?MADV_HUGEPAGE:MADV_NOHUGEPAGE);
  memset(p,1,len);
  double d[60]; volatile long sum=0;
  for(int r=0;r<60;r++){
    struct timespec s={0,100000000}; nanosleep(&s,0);
    double t0=now();
    for(int i=0;i<npages;i++) sum+=p[(size_t)i*stride % len];
    d[r]=now()-t0;
  }
  qsort(d,60,sizeof(double),cmp);
  FILE*f=fopen("/proc/self/smaps_rollup","r"); char line[256]; long ah=0; while(fgets(line,256,f)) if(!strncmp(line,"AnonHugePages",13)) sscanf(line+14,"%ld",&ah);
  printf("n=%d huge=%d stride=%d median %.1f us p10 %.1f p90 %.1f  (AnonHuge %ld kB)\n",npages,huge,stride,d[30]/1e3,d[6]/1e3,d[54]/1e3,ah);
}
