#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdio.h>
#include <time.h>
static double now(void){struct timespec t;clock_gettime(CLOCK_MONOTONIC,&t);return t.tv_sec+1e-9*t.tv_nsec;}
static double tb,tu,td,t0; static long nb,nu,nd;
__attribute__((constructor)) static void init(void){t0=now();}
__attribute__((destructor)) static void fin(void){fprintf(stderr,"shim: wall %.2f blur %ld %.2f s upload %ld %.2f s download %ld %.2f s rest %.2f\n",now()-t0,nb,tb,nu,tu,nd,td,now()-t0-tb-tu-td);}
#define WRAP(name, cnt, acc, sig, args) \
 int name sig { static int (*f) sig; if(!f) f=dlsym(RTLD_NEXT,#name); double s=now(); int r=f args; acc+=now()-s; cnt++; return r; }
WRAP(pb_blur, nb, tb, (void*c,const void*i,const void*m,const void*o,void*out), (c,i,m,o,out))
WRAP(pb_volume_upload, nu, tu, (void*v,const float*h), (v,h))
WRAP(pb_volume_download, nd, td, (const void*v,float*h), (v,h))
