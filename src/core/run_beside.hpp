// Two pieces of host work at once: one on this thread, one beside it on another host thread (a
// TBB task), for a serial step (an edge collapse) that would otherwise leave a core waiting.
#pragma once

#include <tbb/task_group.h>

namespace trilevel {

/// Runs `beside` as a task on another host thread while this thread runs `main`, and returns
/// when both have ended (with one host thread, `beside` runs after `main`). An exception of
/// either is rethrown once both have ended, `main`'s first.
template <class Beside, class Main>
void run_beside(Beside&& beside, Main&& main) {
    tbb::task_group group;
    group.run([&] { beside(); });
    try {
        main();
    } catch (...) {
        group.wait();
        throw;
    }
    group.wait();
}

}  // namespace trilevel
