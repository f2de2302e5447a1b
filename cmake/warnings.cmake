# Project-wide warnings; applied per target with lpstereo_warnings(target).
function(lpstereo_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wno-psabi
    # GCC 12 reports false -Wrestrict positives inside std::string (GCC bug 105329).
    -Wno-restrict
    # Aggregates with defaulted trailing members are initialised partially on purpose.
    -Wno-missing-field-initializers)
  if(LPSTEREO_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
