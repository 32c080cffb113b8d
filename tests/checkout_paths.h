#pragma once

// Where the repository this build was configured from and the ../shared folder beside it lie
// (for tests and benches that read test data, goldens or ../shared/assets). A file the build
// generates defines them, so that no source embeds a path and each compiles the same in any
// checkout (which lets a compiler cache share objects between clones). Link penumbra_checkout_paths.
namespace penumbra::checkout {
extern const char* const kSourceDir;  // the repository root
extern const char* const kSharedDir;  // ../shared beside it (may be absent: skip what needs it)
}  // namespace penumbra::checkout
