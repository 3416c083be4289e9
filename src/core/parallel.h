/* Loops on the machine's cores: a pool of threads, made and joined by its
 * caller (no thread outlives the call that made its pool, so a process that
 * forks between calls forks no pool). Sums are taken in chunks of fixed size
 * added in chunk order, so that they are the same bits whatever the threads. */
#ifndef PB_PARALLEL_H
#define PB_PARALLEL_H

#include <stddef.h>

typedef struct pb_pool pb_pool;
/* Voxels a chunk of a sum; a sum has at most PB_MOST_SUMS terms. */
enum { PB_CHUNK = 16384, PB_MOST_SUMS = 256 };
/* Threads on the cores this process may run on (its CPU affinity; at most
 * 32), the caller one of them; NULL where there is one core or no thread
 * starts: every loop then runs on the caller. */
pb_pool *pb_pool_create(void);
void pb_pool_destroy(pb_pool *pool);
/* The threads that run a loop, the caller's included. */
size_t pb_pool_threads(const pb_pool *pool);
/* fn(user, i) for every i in [0, count), on the pool's threads (NULL: in
 * order on the caller); returns when every call has returned. */
void pb_pool_for(pb_pool *pool, size_t count, void (*fn)(void *user, size_t i), void *user);
/* The chunks of n voxels. */
size_t pb_chunks(size_t n);
/* sums[0..k) = the sums fn adds into its sums (zeroed) over voxels [begin,
 * end), taken chunk by chunk (k <= PB_MOST_SUMS). */
void pb_pool_sums(pb_pool *pool, size_t n, size_t k, void (*fn)(void *user, size_t begin, size_t end, double *sums),
                  void *user, double *sums);

#endif
