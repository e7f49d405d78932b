// Deliberately heap-using program: check_no_heap.cmake must reject it (ctest fw_no_heap_detects_heap,
// WILL_FAIL). It proves the image check can fail.
#include <cstdlib>
#include <new>

volatile int g_sink;

int main() {
  void* p = std::malloc(16);
  int* q = new (std::nothrow) int(3);
  g_sink = (p != nullptr) + *q;
  delete q;
  std::free(p);
  for (;;) {
  }
}
