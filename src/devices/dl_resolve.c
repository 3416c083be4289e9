#include "dl_resolve.h"

#include <dlfcn.h>
#include <string.h>

const char *pb_dl_resolve(void *lib, const char *const *names, void *const *slots, size_t count)
{
    for (size_t i = 0; i < count; i++) {
        void *sym = dlsym(lib, names[i]);
        if (!sym)
            return names[i];
        /* dlsym gives void *; a function pointer is written through memcpy,
         * as POSIX guarantees the two have one representation. */
        memcpy(slots[i], &sym, sizeof sym);
    }
    return NULL;
}
