# Which instruction set each file is compiled for (DESIGN.md §6, "Lane widths").
#
# Kernel files, those that include Highway (core/simd.h) directly or through the project's own
# headers, are compiled for the kernel ISA: the build CPU's (-march=native) by default,
# x86-64-v3 with -DAFTERIMAGE_NATIVE=OFF. Every other file (I/O, the renderer, the CLI, most
# tests) is compiled for the base ISA, x86-64-v3 in both configurations, so that its objects
# are the same in a native and a portable build and ccache compiles them once for both (CI
# builds both on an AVX-512 host, .ci/run).
# With -ffp-contract=off on the kernels' modules and no -ffast-math, a file's results do not
# depend on which of the two it is compiled for; scripts/golden.sh checks it.
#
# x86-64-v3 (AVX2 and FMA: Haswell, Zen and later) is the oldest ISA whose MulAdd is fused as
# the kernels and their bit-exact tests assume. On a host that is not x86-64 or lacks it, the
# base ISA is the kernel ISA.

include(CheckCXXSourceCompiles)

if(AFTERIMAGE_NATIVE)
  set(AFTERIMAGE_KERNEL_ARCH native)
else()
  set(AFTERIMAGE_KERNEL_ARCH x86-64-v3)
endif()
set(AFTERIMAGE_BASE_ARCH ${AFTERIMAGE_KERNEL_ARCH})
if(CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$" AND AFTERIMAGE_NATIVE)
  set(CMAKE_REQUIRED_FLAGS -march=native)
  check_cxx_source_compiles("
    #if !(defined(__AVX2__) && defined(__FMA__) && defined(__BMI2__) && defined(__F16C__))
    #error host lacks x86-64-v3
    #elif !(defined(__LZCNT__) && defined(__MOVBE__))
    #error host lacks x86-64-v3
    #endif
    int main() { return 0; }" AFTERIMAGE_HOST_HAS_X86_64_V3)
  unset(CMAKE_REQUIRED_FLAGS)
  if(AFTERIMAGE_HOST_HAS_X86_64_V3)
    set(AFTERIMAGE_BASE_ARCH x86-64-v3)
  endif()
endif()

# _ai_uses_highway(<file> <out-var>): TRUE when <file> includes a Highway header, directly or
# through a header of this project (memoised per file).
function(_ai_uses_highway file out)
  string(MD5 key "${file}")
  get_property(known GLOBAL PROPERTY _ai_hwy_${key} SET)
  if(known)
    get_property(result GLOBAL PROPERTY _ai_hwy_${key})
    set(${out} ${result} PARENT_SCOPE)
    return()
  endif()
  set_property(GLOBAL PROPERTY _ai_hwy_${key} FALSE)  # an include cycle ends here
  set(result FALSE)
  get_filename_component(dir "${file}" DIRECTORY)
  file(STRINGS "${file}" includes REGEX "^[ \t]*#[ \t]*include[ \t]*[<\"]")
  foreach(line IN LISTS includes)
    if(line MATCHES "<hwy/")
      set(result TRUE)
    elseif(line MATCHES "\"([^\"]+)\"")
      set(name "${CMAKE_MATCH_1}")
      foreach(base "${dir}" ${PROJECT_SOURCE_DIR}/src ${PROJECT_SOURCE_DIR}/include
              ${PROJECT_SOURCE_DIR}/tests ${PROJECT_SOURCE_DIR}/apps ${PROJECT_SOURCE_DIR}/bench)
        if(EXISTS "${base}/${name}" AND NOT IS_DIRECTORY "${base}/${name}")
          _ai_uses_highway("${base}/${name}" sub)
          if(sub)
            set(result TRUE)
          endif()
          break()
        endif()
      endforeach()
    endif()
    if(result)
      break()
    endif()
  endforeach()
  set_property(GLOBAL PROPERTY _ai_hwy_${key} ${result})
  set(${out} ${result} PARENT_SCOPE)
endfunction()

# afterimage_assign_isa(<dir>): gives every C/C++ source of every target defined in <dir> and
# below its -march: the ISA most of a target's files need on the target, the other on its
# files (a file with its own flags is compiled alone in a unity build). A kernel file is
# compiled with AFTERIMAGE_KERNEL_ISA, without which core/simd.h refuses to compile, so a file
# this scan misread (or a target it never saw) fails to build instead of running kernels for
# the wrong ISA.
function(afterimage_assign_isa dir)
  get_property(targets DIRECTORY "${dir}" PROPERTY BUILDSYSTEM_TARGETS)
  foreach(t IN LISTS targets)
    get_target_property(type ${t} TYPE)
    if(type STREQUAL "INTERFACE_LIBRARY" OR type STREQUAL "UTILITY")
      continue()
    endif()
    get_target_property(sources ${t} SOURCES)
    get_target_property(source_dir ${t} SOURCE_DIR)
    set(kernel_files)
    set(base_files)
    foreach(s IN LISTS sources)
      if(s MATCHES "\\$<" OR NOT s MATCHES "\\.(cpp|cc|c)$")
        continue()
      endif()
      cmake_path(ABSOLUTE_PATH s BASE_DIRECTORY "${source_dir}" OUTPUT_VARIABLE path)
      _ai_uses_highway("${path}" kernel)
      if(kernel)
        list(APPEND kernel_files "${path}")
      else()
        list(APPEND base_files "${path}")
      endif()
    endforeach()
    list(LENGTH kernel_files n_kernel)
    list(LENGTH base_files n_base)
    set(kernel_flags -march=${AFTERIMAGE_KERNEL_ARCH} -DAFTERIMAGE_KERNEL_ISA)
    set(base_flags -march=${AFTERIMAGE_BASE_ARCH} -UAFTERIMAGE_KERNEL_ISA)
    if(n_kernel GREATER n_base)
      target_compile_options(${t} PRIVATE ${kernel_flags})
      set(own_files ${base_files})
      set(own_flags ${base_flags})
    else()
      target_compile_options(${t} PRIVATE ${base_flags})
      set(own_files ${kernel_files})
      set(own_flags ${kernel_flags})
    endif()
    foreach(path IN LISTS own_files)
      get_property(done SOURCE "${path}" TARGET_DIRECTORY ${t} PROPERTY _AI_ISA SET)
      if(NOT done)  # a file two targets of one directory share gets its flags once
        set_property(SOURCE "${path}" TARGET_DIRECTORY ${t} APPEND PROPERTY
                     COMPILE_OPTIONS ${own_flags})
        set_property(SOURCE "${path}" TARGET_DIRECTORY ${t} PROPERTY _AI_ISA TRUE)
      endif()
    endforeach()
  endforeach()
  get_property(subdirs DIRECTORY "${dir}" PROPERTY SUBDIRECTORIES)
  foreach(d IN LISTS subdirs)
    afterimage_assign_isa("${d}")
  endforeach()
endfunction()
