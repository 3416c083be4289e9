/* Loops on the machine's cores (parallel.h): the estimate's host loops,
 * which on a GPU are most of an estimate's time (docs/motion.md, "What
 * bounds its time"), and the host backend's forward. */
#define _GNU_SOURCE /* sched_getaffinity: the cores this process may run on */
#include <pthread.h>
#include <sched.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "parallel.h"

/* More threads than this find the loops bound by memory, not cores. */
enum { MOST_THREADS = 32 };

struct pb_pool {
    pthread_t threads[MOST_THREADS];
    size_t count; /* threads started, besides the caller */
    pthread_mutex_t lock;
    pthread_cond_t wake, done;
    unsigned long generation; /* one a job */
    int quit;
    /* the job: fn(user, i) for i in [0, total) */
    void (*fn)(void *user, size_t i);
    void *user;
    size_t total, next, finished, busy;
};

/* Takes the job's items until none is left; called and returns with the lock held. */
static void take_items(pb_pool *p)
{
    while (p->next < p->total) {
        size_t i = p->next++;
        pthread_mutex_unlock(&p->lock);
        p->fn(p->user, i);
        pthread_mutex_lock(&p->lock);
        p->finished++;
    }
}

static void *worker(void *arg)
{
    pb_pool *p = arg;
    unsigned long seen = 0;
    pthread_mutex_lock(&p->lock);
    for (;;) {
        while (p->generation == seen && !p->quit)
            pthread_cond_wait(&p->wake, &p->lock);
        if (p->quit)
            break;
        seen = p->generation;
        p->busy++;
        take_items(p);
        /* the caller returns (and its job's user with it) only when no
         * worker still holds an item of it */
        if (--p->busy == 0 && p->finished == p->total)
            pthread_cond_signal(&p->done);
    }
    pthread_mutex_unlock(&p->lock);
    return NULL;
}

static size_t cores(void)
{
    cpu_set_t set;
    if (sched_getaffinity(0, sizeof set, &set) == 0 && CPU_COUNT(&set) > 0)
        return (size_t)CPU_COUNT(&set);
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? (size_t)n : 1;
}

pb_pool *pb_pool_create(void)
{
    size_t want = cores();
    if (want > MOST_THREADS)
        want = MOST_THREADS;
    if (want < 2)
        return NULL;
    pb_pool *p = calloc(1, sizeof *p);
    if (!p)
        return NULL;
    if (pthread_mutex_init(&p->lock, NULL) != 0) {
        free(p);
        return NULL;
    }
    if (pthread_cond_init(&p->wake, NULL) != 0 || pthread_cond_init(&p->done, NULL) != 0) {
        pthread_mutex_destroy(&p->lock);
        free(p);
        return NULL;
    }
    /* the caller takes items too: one thread fewer than the cores */
    for (size_t i = 0; i + 1 < want; i++) {
        if (pthread_create(&p->threads[i], NULL, worker, p) != 0)
            break;
        p->count++;
    }
    if (p->count == 0) {
        pb_pool_destroy(p);
        return NULL;
    }
    return p;
}

void pb_pool_destroy(pb_pool *p)
{
    if (!p)
        return;
    pthread_mutex_lock(&p->lock);
    p->quit = 1;
    pthread_cond_broadcast(&p->wake);
    pthread_mutex_unlock(&p->lock);
    for (size_t i = 0; i < p->count; i++)
        pthread_join(p->threads[i], NULL);
    pthread_cond_destroy(&p->wake);
    pthread_cond_destroy(&p->done);
    pthread_mutex_destroy(&p->lock);
    free(p);
}

size_t pb_pool_threads(const pb_pool *p)
{
    return p ? p->count + 1 : 1;
}

void pb_pool_for(pb_pool *p, size_t count, void (*fn)(void *user, size_t i), void *user)
{
    if (!p || count < 2) {
        for (size_t i = 0; i < count; i++)
            fn(user, i);
        return;
    }
    pthread_mutex_lock(&p->lock);
    p->fn = fn;
    p->user = user;
    p->total = count;
    p->next = p->finished = 0;
    p->generation++;
    pthread_cond_broadcast(&p->wake);
    take_items(p);
    while (p->finished < p->total || p->busy > 0)
        pthread_cond_wait(&p->done, &p->lock);
    pthread_mutex_unlock(&p->lock);
}

size_t pb_chunks(size_t n)
{
    return (n + PB_CHUNK - 1) / PB_CHUNK;
}

typedef struct chunked {
    size_t n, k;
    void (*fn)(void *user, size_t begin, size_t end, double *sums);
    void *user;
    double *partial;
} chunked;

/* Chunk c's sums into out (k of them). They are added up on the thread's
 * own stack: neighbouring chunks' sums share cache lines, and a thread that
 * adds into them at every voxel stalls the others. */
static void chunk_sums(const chunked *s, size_t c, double *out)
{
    size_t begin = c * PB_CHUNK, end = begin + PB_CHUNK < s->n ? begin + PB_CHUNK : s->n;
    double own[PB_MOST_SUMS];
    memset(own, 0, sizeof(double) * s->k);
    s->fn(s->user, begin, end, own);
    memcpy(out, own, sizeof(double) * s->k);
}

static void sum_chunk(void *arg, size_t c)
{
    const chunked *s = arg;
    chunk_sums(s, c, s->partial + c * s->k);
}

void pb_pool_sums(pb_pool *p, size_t n, size_t k, void (*fn)(void *user, size_t begin, size_t end, double *sums),
                   void *user, double *sums)
{
    const size_t chunks = pb_chunks(n);
    chunked s = {n, k, fn, user, p && chunks > 1 ? malloc(sizeof(double) * k * chunks) : NULL};
    memset(sums, 0, sizeof(double) * k);
    if (s.partial) {
        pb_pool_for(p, chunks, sum_chunk, &s);
        for (size_t c = 0; c < chunks; c++)
            for (size_t j = 0; j < k; j++)
                sums[j] += s.partial[c * k + j];
        free(s.partial);
        return;
    }
    /* on the caller, a chunk at a time: the same sums added in the same order */
    double one[PB_MOST_SUMS];
    for (size_t c = 0; c < chunks; c++) {
        chunk_sums(&s, c, one);
        for (size_t j = 0; j < k; j++)
            sums[j] += one[j];
    }
}
