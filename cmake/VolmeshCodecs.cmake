# SPDX-License-Identifier: BSD-3-Clause
# The optional decoders of compressed DICOM pixel data (io/dicom_codecs.c): libjpeg-turbo,
# CharLS and OpenJPEG, each found, then verified by building and linking a program that calls
# the decoder functions the reader uses; else off with one status line saying why. Sets
# VM_DICOM_JPEG_FOUND, VM_DICOM_JPEGLS_FOUND, VM_DICOM_J2K_FOUND, and for the library target
# VM_CODEC_DEFINITIONS, VM_CODEC_INCLUDE_DIRS and VM_CODEC_LIBRARIES (absolute paths, so that
# the installed CMake package needs no find modules), and VM_PC_CODECS for volmesh.pc.
include(CheckCSourceCompiles)
set(VM_CODEC_DEFINITIONS "")
set(VM_CODEC_INCLUDE_DIRS "")
set(VM_CODEC_LIBRARIES "")
set(VM_PC_CODECS "")

# vm_codec_check(RESULT INCLUDES LIBRARIES SOURCE): RESULT is ON when SOURCE compiles and links.
function(vm_codec_check result includes libraries source)
  unset(${result} CACHE)
  set(CMAKE_REQUIRED_INCLUDES ${includes})
  set(CMAKE_REQUIRED_LIBRARIES ${libraries})
  set(CMAKE_REQUIRED_QUIET ON)
  check_c_source_compiles("${source}" ${result})
  set(${result} ${${result}} PARENT_SCOPE)
endfunction()

# JPEG (1.2.840.10008.1.2.4.50, .51, .57, .70) with libjpeg-turbo. 8-bit samples need
# jpeg_mem_src (libjpeg-turbo 1.3 and later); 12-bit lossy and lossless JPEG need the
# jpeg12_ and jpeg16_ functions and jpeg_enable_lossless of libjpeg-turbo 3.0.
set(VM_DICOM_JPEG_FOUND OFF)
set(VM_DICOM_JPEG_LOSSLESS OFF)
set(VM_DICOM_JPEG_WHY "VOLMESH_DICOM_JPEG is OFF")
if(VOLMESH_DICOM_JPEG)
  find_package(JPEG QUIET)
  if(NOT JPEG_FOUND)
    set(VM_DICOM_JPEG_WHY "libjpeg not found (Debian: libjpeg62-turbo-dev)")
  else()
    vm_codec_check(VM_JPEG_WORKS "${JPEG_INCLUDE_DIRS}" "${JPEG_LIBRARIES}" "#include <stdio.h>
#include <jpeglib.h>
int main(void) {
  struct jpeg_decompress_struct d; struct jpeg_error_mgr e;
  static const unsigned char b[2] = {0xFF, 0xD8};
  d.err = jpeg_std_error(&e);
  jpeg_create_decompress(&d);
  jpeg_mem_src(&d, b, sizeof b);
  jpeg_destroy_decompress(&d);
  return 0;
}")
    set(vm_jpeg_version "")
    foreach(dir ${JPEG_INCLUDE_DIRS} /usr/include/${CMAKE_LIBRARY_ARCHITECTURE})
      if(NOT vm_jpeg_version AND EXISTS ${dir}/jconfig.h)
        file(STRINGS ${dir}/jconfig.h vm_line REGEX "define LIBJPEG_TURBO_VERSION ")
        if(vm_line MATCHES "LIBJPEG_TURBO_VERSION +([0-9.]+)")
          set(vm_jpeg_version "libjpeg-turbo ${CMAKE_MATCH_1}")
        endif()
      endif()
    endforeach()
    if(NOT vm_jpeg_version)
      set(vm_jpeg_version "libjpeg ${JPEG_VERSION}")
    endif()
    if(VM_JPEG_WORKS)
      set(VM_DICOM_JPEG_FOUND ON)
      vm_codec_check(VM_JPEG16_WORKS "${JPEG_INCLUDE_DIRS}" "${JPEG_LIBRARIES}" "#include <stdio.h>
#include <jpeglib.h>
int main(void) {
  struct jpeg_decompress_struct d; struct jpeg_error_mgr e;
  J12SAMPROW r12 = 0; J16SAMPROW r16 = 0;
  d.err = jpeg_std_error(&e);
  jpeg_create_decompress(&d);
  if (d.data_precision == 12) jpeg12_read_scanlines(&d, &r12, 1);
  if (d.data_precision == 16) jpeg16_read_scanlines(&d, &r16, 1);
  jpeg_destroy_decompress(&d);
  return 0;
}")
      set(VM_DICOM_JPEG_LOSSLESS ${VM_JPEG16_WORKS})
      list(APPEND VM_CODEC_DEFINITIONS VM_HAVE_DICOM_JPEG)
      list(APPEND VM_CODEC_INCLUDE_DIRS ${JPEG_INCLUDE_DIRS})
      list(APPEND VM_CODEC_LIBRARIES ${JPEG_LIBRARIES})
      string(APPEND VM_PC_CODECS " libjpeg")
      if(VM_DICOM_JPEG_LOSSLESS)
        list(APPEND VM_CODEC_DEFINITIONS VM_HAVE_DICOM_JPEG16)
        set(VM_DICOM_JPEG_WHAT "${vm_jpeg_version}: 8 and 12-bit lossy, lossless")
      else()
        set(VM_DICOM_JPEG_WHAT "${vm_jpeg_version}: 8-bit baseline and extended; 12-bit and lossless JPEG need libjpeg-turbo 3.0")
      endif()
    else()
      set(VM_DICOM_JPEG_WHY "a test program decoding from memory does not build against ${vm_jpeg_version} (${JPEG_LIBRARIES})")
    endif()
  endif()
endif()
if(VM_DICOM_JPEG_FOUND)
  message(STATUS "volmesh: DICOM JPEG ON (${VM_DICOM_JPEG_WHAT})")
else()
  message(STATUS "volmesh: DICOM JPEG OFF (${VM_DICOM_JPEG_WHY}): JPEG-compressed DICOM is refused")
endif()

# JPEG-LS (1.2.840.10008.1.2.4.80, .81) with CharLS 2.1 or later (its C decoder API).
set(VM_DICOM_JPEGLS_FOUND OFF)
set(VM_DICOM_JPEGLS_WHY "VOLMESH_DICOM_JPEGLS is OFF")
if(VOLMESH_DICOM_JPEGLS)
  find_path(VM_CHARLS_INCLUDE_DIR charls/charls.h)
  find_library(VM_CHARLS_LIBRARY NAMES charls CharLS)
  if(NOT VM_CHARLS_INCLUDE_DIR OR NOT VM_CHARLS_LIBRARY)
    set(VM_DICOM_JPEGLS_WHY "CharLS not found (Debian: libcharls-dev)")
  else()
    set(vm_charls_version "CharLS")
    if(EXISTS ${VM_CHARLS_INCLUDE_DIR}/charls/version.h)
      file(STRINGS ${VM_CHARLS_INCLUDE_DIR}/charls/version.h vm_lines
           REGEX "define CHARLS_VERSION_(MAJOR|MINOR|PATCH) ")
      string(REGEX REPLACE "[^;]*CHARLS_VERSION_[A-Z]+ +([0-9]+)" "\\1" vm_parts "${vm_lines}")
      string(REPLACE ";" "." vm_parts "${vm_parts}")
      set(vm_charls_version "CharLS ${vm_parts}")
    endif()
    vm_codec_check(VM_CHARLS_WORKS "${VM_CHARLS_INCLUDE_DIR}" "${VM_CHARLS_LIBRARY}" "#include <charls/charls.h>
int main(void) {
  charls_jpegls_decoder *d = charls_jpegls_decoder_create();
  charls_frame_info fi;
  static const unsigned char b[2] = {0xFF, 0xD8};
  int bad = charls_jpegls_decoder_set_source_buffer(d, b, sizeof b) != CHARLS_JPEGLS_ERRC_SUCCESS ||
            charls_jpegls_decoder_read_header(d) != CHARLS_JPEGLS_ERRC_SUCCESS ||
            charls_jpegls_decoder_get_frame_info(d, &fi) != CHARLS_JPEGLS_ERRC_SUCCESS;
  charls_jpegls_decoder_destroy(d);
  return bad && charls_get_error_message(CHARLS_JPEGLS_ERRC_SUCCESS) == 0;
}")
    if(VM_CHARLS_WORKS)
      set(VM_DICOM_JPEGLS_FOUND ON)
      list(APPEND VM_CODEC_DEFINITIONS VM_HAVE_DICOM_JPEGLS)
      list(APPEND VM_CODEC_INCLUDE_DIRS ${VM_CHARLS_INCLUDE_DIR})
      list(APPEND VM_CODEC_LIBRARIES ${VM_CHARLS_LIBRARY})
      string(APPEND VM_PC_CODECS " charls")
    else()
      set(VM_DICOM_JPEGLS_WHY "a test program calling the charls_jpegls_decoder functions does not build against ${vm_charls_version} (${VM_CHARLS_LIBRARY}; 2.1 or later is needed)")
    endif()
  endif()
endif()
if(VM_DICOM_JPEGLS_FOUND)
  message(STATUS "volmesh: DICOM JPEG-LS ON (${vm_charls_version})")
else()
  message(STATUS "volmesh: DICOM JPEG-LS OFF (${VM_DICOM_JPEGLS_WHY}): JPEG-LS DICOM is refused")
endif()

# JPEG 2000 (1.2.840.10008.1.2.4.90, .91) with OpenJPEG 2.3 or later; its strict mode
# (2.5: a truncated codestream is an error, not a partial image) is used when present.
set(VM_DICOM_J2K_FOUND OFF)
set(VM_DICOM_J2K_WHY "VOLMESH_DICOM_J2K is OFF")
if(VOLMESH_DICOM_J2K)
  find_path(VM_OPJ_INCLUDE_DIR openjpeg.h
            PATH_SUFFIXES openjpeg-2.5 openjpeg-2.4 openjpeg-2.3)
  find_library(VM_OPJ_LIBRARY NAMES openjp2)
  if(NOT VM_OPJ_INCLUDE_DIR OR NOT VM_OPJ_LIBRARY)
    set(VM_DICOM_J2K_WHY "OpenJPEG not found (Debian: libopenjp2-7-dev)")
  else()
    set(vm_opj_version "OpenJPEG")
    if(EXISTS ${VM_OPJ_INCLUDE_DIR}/opj_config.h)
      file(STRINGS ${VM_OPJ_INCLUDE_DIR}/opj_config.h vm_lines
           REGEX "define OPJ_VERSION_(MAJOR|MINOR|BUILD) ")
      string(REGEX REPLACE "[^;]*OPJ_VERSION_[A-Z]+ +([0-9]+)" "\\1" vm_parts "${vm_lines}")
      string(REPLACE ";" "." vm_parts "${vm_parts}")
      set(vm_opj_version "OpenJPEG ${vm_parts}")
    endif()
    vm_codec_check(VM_OPJ_WORKS "${VM_OPJ_INCLUDE_DIR}" "${VM_OPJ_LIBRARY}" "#include <openjpeg.h>
int main(void) {
  opj_dparameters_t p;
  opj_codec_t *c = opj_create_decompress(OPJ_CODEC_J2K);
  opj_stream_t *s = opj_stream_create(4096, OPJ_TRUE);
  opj_set_default_decoder_parameters(&p);
  int bad = !opj_setup_decoder(c, &p);
  opj_stream_destroy(s);
  opj_destroy_codec(c);
  return bad;
}")
    if(VM_OPJ_WORKS)
      set(VM_DICOM_J2K_FOUND ON)
      vm_codec_check(VM_OPJ_STRICT "${VM_OPJ_INCLUDE_DIR}" "${VM_OPJ_LIBRARY}" "#include <openjpeg.h>
int main(void) {
  opj_codec_t *c = opj_create_decompress(OPJ_CODEC_J2K);
  int bad = !opj_decoder_set_strict_mode(c, OPJ_TRUE);
  opj_destroy_codec(c);
  return bad;
}")
      list(APPEND VM_CODEC_DEFINITIONS VM_HAVE_DICOM_J2K)
      if(VM_OPJ_STRICT)
        list(APPEND VM_CODEC_DEFINITIONS VM_HAVE_OPJ_STRICT)
      endif()
      list(APPEND VM_CODEC_INCLUDE_DIRS ${VM_OPJ_INCLUDE_DIR})
      list(APPEND VM_CODEC_LIBRARIES ${VM_OPJ_LIBRARY})
      string(APPEND VM_PC_CODECS " libopenjp2")
    else()
      set(VM_DICOM_J2K_WHY "a test program setting up an OpenJPEG decoder does not build against ${vm_opj_version} (${VM_OPJ_LIBRARY})")
    endif()
  endif()
endif()
if(VM_DICOM_J2K_FOUND)
  message(STATUS "volmesh: DICOM JPEG 2000 ON (${vm_opj_version})")
else()
  message(STATUS "volmesh: DICOM JPEG 2000 OFF (${VM_DICOM_J2K_WHY}): JPEG 2000 DICOM is refused")
endif()
