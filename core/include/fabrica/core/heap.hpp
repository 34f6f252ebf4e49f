// The process heap between the phases of a one-shot computation.
#pragma once

namespace fabrica {

/// Returns the heap's free pages to the system (glibc: malloc_trim; elsewhere
/// nothing). The allocator keeps the pages of freed blocks resident until it
/// reuses them; a one-shot drawing (`fabrica lines`) calls this after a phase
/// that freed more than the next one reuses (the reader's arrays after the
/// load, the view fields after the extraction), so that the freed pages do
/// not count in the peak resident set of the phases after it
/// (docs/PERFORMANCE.md, peak memory). Costs a walk over the free blocks and
/// fresh page faults where they are used again.
void return_free_heap_pages();

}  // namespace fabrica
