# blobvk_warnings(target): strict warnings on our own code only (third-party headers are SYSTEM).
function(blobvk_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Werror -Wno-missing-field-initializers)
endfunction()
