# cmake -DNM=<arm-none-eabi-nm> -DELF=<image> -P check_no_heap.cmake
cmake_minimum_required(VERSION 3.25)
# Fails (FATAL_ERROR) if the linked image defines or references any heap allocator or the exception
# allocator: malloc, free, calloc, realloc (and their newlib _r variants), operator new/delete in every
# overload (_Znwj, _Znaj, _ZdlPv, _ZdaPv, ...), __cxa_allocate_exception.
if(NOT NM OR NOT ELF)
  message(FATAL_ERROR "usage: cmake -DNM=... -DELF=... -P check_no_heap.cmake")
endif()
execute_process(COMMAND ${NM} ${ELF} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "nm failed on ${ELF}: ${err}")
endif()
string(REPLACE "\n" ";" lines "${out}")
set(bad "")
foreach(line IN LISTS lines)
  # nm lines: "<addr> <type> <name>" or "         U <name>"
  if(line MATCHES "[ \t]([A-Za-z])[ \t]+([^ \t]+)$")
    set(sym "${CMAKE_MATCH_2}")
    if(sym MATCHES "^_?(malloc|free|calloc|realloc|reallocf|memalign|aligned_alloc|posix_memalign)$"
       OR sym MATCHES "^_(malloc|free|calloc|realloc|memalign)_r$"
       OR sym MATCHES "^_Z(nw|na|dl|da)[jmPSt]"
       OR sym STREQUAL "__cxa_allocate_exception")
      list(APPEND bad "${sym}")
    endif()
  endif()
endforeach()
list(LENGTH lines nlines)
if(bad)
  list(REMOVE_DUPLICATES bad)
  message(FATAL_ERROR "${ELF} uses the heap: ${bad}")
endif()
message(STATUS "${ELF}: no heap symbols among ${nlines} symbols")
