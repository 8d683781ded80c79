# ASan + UBSan for every target when WEFT_SANITIZE is on (preset "asan").
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
