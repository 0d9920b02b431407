#pragma once

namespace tetrascope::storage {

// Whether this is an AddressSanitizer build (clang's __has_feature or gcc's macro). Such a build
// reserves terabytes of shadow address space (no RLIMIT_AS on its children), its allocator is
// not safe in a child forked from several threads, and it runs minutes where release runs
// seconds.
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kAddressSanitizer = true;
#elif defined(__has_feature)
constexpr bool kAddressSanitizer = __has_feature(address_sanitizer);
#else
constexpr bool kAddressSanitizer = false;
#endif

}  // namespace tetrascope::storage
