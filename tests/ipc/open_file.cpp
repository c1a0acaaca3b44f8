// SPDX-License-Identifier: Apache-2.0
// Opens a file the way a hostile client would try a shared-memory segment, with open(2):
//   open_file PATH rw|r
// Prints "opened" (exit 0), or the errno's name, e.g. "EACCES" (exit 1).
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

int main(int argc, char** argv) {
    if (argc != 3 || (std::strcmp(argv[2], "rw") != 0 && std::strcmp(argv[2], "r") != 0)) {
        std::fprintf(stderr, "usage: open_file PATH rw|r\n");
        return 2;
    }
    const int flags = (std::strcmp(argv[2], "rw") == 0 ? O_RDWR : O_RDONLY) | O_CLOEXEC;
    const int fd = ::open(argv[1], flags);
    if (fd < 0) {
        const int error = errno;
        std::printf("%s\n", error == EACCES ? "EACCES" : error == EPERM ? "EPERM" : std::strerror(error));
        return 1;
    }
    ::close(fd);
    std::printf("opened\n");
    return 0;
}
