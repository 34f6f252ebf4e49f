#include "fabrica/core/heap.hpp"

#include <cstdlib>  // (defines __GLIBC__ with the GNU C library)

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace fabrica {

void return_free_heap_pages() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

}  // namespace fabrica
