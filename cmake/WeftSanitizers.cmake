# ASan + UBSan for every target when WEFT_SANITIZE is on (preset "asan"); ThreadSanitizer when
# WEFT_TSAN is on (preset "tsan"; tools/tsan.supp names what it does not report, and why).
if(WEFT_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()
# libFuzzer's coverage plus ASan + UBSan for every target when WEFT_FUZZ is on (preset
# "fuzz"); only the harnesses (tests/fuzz) link the fuzzer's main.
if(WEFT_FUZZ)
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()
if(WEFT_TSAN)
  if(WEFT_SANITIZE OR WEFT_FUZZ)
    message(FATAL_ERROR "WEFT_TSAN cannot be combined with WEFT_SANITIZE or WEFT_FUZZ (ThreadSanitizer excludes ASan)")
  endif()
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
  add_link_options(-fsanitize=thread)
endif()
