// AllocationGuard: counts heap allocations made by the current thread while it is alive.
// Linked into every test binary; it replaces global operator new/delete and (outside sanitizer
// builds, on glibc) malloc/calloc/realloc/free, so tests can assert "zero allocations".
#pragma once

#include <cstddef>

namespace dynamap::test {

class AllocationGuard {
 public:
  AllocationGuard() noexcept;
  ~AllocationGuard();
  AllocationGuard(const AllocationGuard&) = delete;
  AllocationGuard& operator=(const AllocationGuard&) = delete;

  /// Allocations (new, new[], malloc, calloc, realloc) on this thread since construction.
  std::size_t allocations() const noexcept;
  /// Deallocations (delete, delete[], free) on this thread since construction.
  std::size_t deallocations() const noexcept;

 private:
  std::size_t start_alloc_;
  std::size_t start_free_;
  bool outer_active_;
};

/// True when malloc itself is counted (false in sanitizer builds, where only new/delete are).
bool malloc_is_counted() noexcept;

}  // namespace dynamap::test
