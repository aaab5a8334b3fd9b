// The one reader of every file lancer reads (scenes, images given to compare, plot's CSV): the
// whole file in memory, bounded, from regular files only.
#pragma once

#include <cstddef>
#include <string>

namespace lancer {

// Reads the regular file `path` whole, refusing (InputError naming the path) a folder, anything
// that is not a regular file (a FIFO, a device such as /dev/zero, a socket: they could block or
// never end), and a file over `max_bytes`. The file is opened without blocking, so a FIFO with no
// writer is refused rather than waited on. `what` names the kind of file in messages ("scene
// file"); `limit` is max_bytes in words ("1 GiB"). Running out of memory is an InputError too.
std::string read_input_file(const std::string& path, std::size_t max_bytes, const char* what,
                            const char* limit);

}  // namespace lancer
