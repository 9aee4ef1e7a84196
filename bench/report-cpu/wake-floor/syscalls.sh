#!/bin/bash
# usage: count.sh BIN_DIR  -> syscalls per second per process name and per syscall, over 10 s of a paced run
BIN=${1:-/work/main/target/deploy}
T=/sys/kernel/tracing
cd /tmp/sys && rm -rf run && mkdir run
$BIN/testbed run --profile simulation --mode paced --duration 30 --log /tmp/sys/run/x.mcap > run/out.txt 2>&1 &
sleep 10
echo > $T/trace; echo 40000 > $T/buffer_size_kb
echo 1 > $T/events/raw_syscalls/sys_enter/enable
echo 1 > $T/tracing_on; sleep 10; echo 0 > $T/tracing_on
echo 0 > $T/events/raw_syscalls/sys_enter/enable
cat $T/trace > run/trace.txt
wait
python3 - <<'PY'
import re,collections
c=collections.Counter(); per=collections.defaultdict(collections.Counter)
names={0:'read',1:'write',7:'poll',202:'futex',228:'clock_gettime',230:'clock_nanosleep',35:'nanosleep',24:'sched_yield',232:'epoll_wait',281:'epoll_pwait',44:'sendto',45:'recvfrom',72:'fcntl',5:'fstat',8:'lseek',9:'mmap',11:'munmap',3:'close',257:'openat',262:'newfstatat',39:'getpid',186:'gettid',17:'pread64',18:'pwrite64',13:'rt_sigaction',14:'rt_sigprocmask',16:'ioctl',21:'access',318:'getrandom',96:'gettimeofday',62:'kill',61:'wait4',247:'waitid',332:'statx',217:'getdents64',89:'readlink',4:'stat',6:'lstat',20:'writev',19:'readv',74:'fsync',75:'fdatasync',271:'ppoll',270:'pselect6',23:'select',273:'set_robust_list',334:'rseq',204:'sched_getaffinity',99:'sysinfo',97:'getrlimit',302:'prlimit64',10:'mprotect',28:'madvise',12:'brk',25:'mremap',77:'ftruncate',285:'fallocate',76:'truncate',33:'dup2',292:'dup3',41:'socket',42:'connect',43:'accept',288:'accept4',46:'sendmsg',47:'recvmsg',54:'setsockopt',55:'getsockopt',233:'epoll_ctl',291:'epoll_create1',290:'eventfd2',283:'timerfd_create',286:'timerfd_settime',56:'clone',435:'clone3',60:'exit',231:'exit_group',102:'getuid',107:'geteuid',110:'getppid',137:'statfs',138:'fstatfs',82:'rename',87:'unlink',83:'mkdir',84:'rmdir',90:'chmod',91:'fchmod',93:'fchown',73:'flock',32:'dup',293:'pipe2',22:'pipe',63:'uname',158:'arch_prctl',218:'set_tid_address',302:'prlimit64',324:'membarrier',425:'io_uring_setup',426:'io_uring_enter'}
for line in open('run/trace.txt'):
    m=re.match(r'\s*(.+?)-(\d+)\s+\[\d+\].*sys_enter: NR (\d+)',line)
    if not m: continue
    comm=m.group(1).strip(); nr=int(m.group(3))
    c[comm]+=1; per[comm][names.get(nr,str(nr))]+=1
for comm,n in c.most_common():
    print(f"{comm:20s} {n/10:8.1f}/s  "+", ".join(f"{k} {v/10:.1f}" for k,v in per[comm].most_common(8)))
print("all", sum(c.values())/10)
PY
