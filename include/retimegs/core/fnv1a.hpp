#pragma once
// FNV-1a 64, the one checksum of the project: of a .rgs file's bytes (model/model_file.hpp) and of
// each file of a checkpoint's manifest (train/checkpoint.hpp). It catches damage and files mixed
// up between checkpoints, not forgery, and needs no dependency.
#include <cstddef>
#include <cstdint>
#include <filesystem>

namespace retimegs {

constexpr std::uint64_t kFnv1a64Basis = 0xcbf29ce484222325ull;  // FNV offset basis

// The hash of the `size` bytes at `data`, continuing from `hash` (the basis starts a new one).
std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t hash = kFnv1a64Basis);

// The hash of the bytes of `file`; throws Error naming it when it cannot be read whole.
std::uint64_t fnv1a64_file(const std::filesystem::path& file);

}  // namespace retimegs
