#include "alloc_guard.hpp"

#include <cstdlib>
#include <new>

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define DYNAMAP_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define DYNAMAP_SANITIZED 1
#endif
#endif

namespace {
// Counters are thread-local so another thread's allocations never leak into a guard.
thread_local std::size_t t_allocs = 0;
thread_local std::size_t t_frees = 0;
thread_local bool t_active = false;

inline void count_alloc() noexcept {
  if (t_active) ++t_allocs;
}
inline void count_free() noexcept {
  if (t_active) ++t_frees;
}
}  // namespace

#if !defined(DYNAMAP_SANITIZED) && defined(__GLIBC__)
// glibc exports its allocator under these names; wrapping them lets us count plain malloc too.
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void __libc_free(void*);

void* malloc(std::size_t n) {
  count_alloc();
  return __libc_malloc(n);
}
void* calloc(std::size_t a, std::size_t b) {
  count_alloc();
  return __libc_calloc(a, b);
}
void* realloc(void* p, std::size_t n) {
  count_alloc();
  return __libc_realloc(p, n);
}
void free(void* p) {
  if (p != nullptr) count_free();
  __libc_free(p);
}
}
#define DYNAMAP_MALLOC_COUNTED 1
// new/delete go through malloc/free above, so they are counted there.
#define COUNT_NEW() ((void)0)
#define COUNT_DELETE() ((void)0)
#else
#define COUNT_NEW() count_alloc()
#define COUNT_DELETE() count_free()
#endif

// Replacing operator new/delete makes the count independent of how the C++ runtime allocates.
void* operator new(std::size_t n) {
  COUNT_NEW();
  if (void* p = std::malloc(n ? n : 1)) return p;
  std::abort();  // tests never run out of memory; works with -fno-exceptions too
}
void* operator new[](std::size_t n) {
  COUNT_NEW();
  if (void* p = std::malloc(n ? n : 1)) return p;
  std::abort();  // tests never run out of memory; works with -fno-exceptions too
}
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  COUNT_NEW();
  return std::malloc(n ? n : 1);
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  COUNT_NEW();
  return std::malloc(n ? n : 1);
}
void* operator new(std::size_t n, std::align_val_t a) {
  COUNT_NEW();
  std::size_t al = static_cast<std::size_t>(a);
  if (void* p = std::aligned_alloc(al, (n + al - 1) / al * al)) return p;
  std::abort();  // tests never run out of memory; works with -fno-exceptions too
}
void* operator new[](std::size_t n, std::align_val_t a) {
  return operator new(n, a);
}
void operator delete(void* p) noexcept {
  if (p) COUNT_DELETE();
  std::free(p);
}
void operator delete[](void* p) noexcept {
  operator delete(p);
}
void operator delete(void* p, std::size_t) noexcept {
  operator delete(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  operator delete(p);
}
void operator delete(void* p, std::align_val_t) noexcept {
  operator delete(p);
}
void operator delete[](void* p, std::align_val_t) noexcept {
  operator delete(p);
}
void operator delete(void* p, std::size_t, std::align_val_t) noexcept {
  operator delete(p);
}
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept {
  operator delete(p);
}

namespace dynamap::test {

AllocationGuard::AllocationGuard() noexcept
    : start_alloc_(t_allocs), start_free_(t_frees), outer_active_(t_active) {
  t_active = true;
}
AllocationGuard::~AllocationGuard() {
  t_active = outer_active_;
}
std::size_t AllocationGuard::allocations() const noexcept {
  return t_allocs - start_alloc_;
}
std::size_t AllocationGuard::deallocations() const noexcept {
  return t_frees - start_free_;
}

bool malloc_is_counted() noexcept {
#ifdef DYNAMAP_MALLOC_COUNTED
  return true;
#else
  return false;
#endif
}

}  // namespace dynamap::test
