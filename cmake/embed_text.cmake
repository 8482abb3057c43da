# Writes a C++ source holding a text file as a string (build time; rewritten only on change).
# Inputs: INPUT (the file), OUTPUT (the .cpp), SYMBOL (the variable, in namespace millsim).
file(READ "${INPUT}" content)
string(FIND "${content}" ")millsim_text\"" clash)
if(NOT clash EQUAL -1)
  message(FATAL_ERROR "${INPUT} contains the raw-string delimiter")
endif()
set(text "// Generated from ${INPUT} by cmake/embed_text.cmake; do not edit.\n\
namespace millsim {\nextern const char* const ${SYMBOL};\n\
const char* const ${SYMBOL} = R\"millsim_text(${content})millsim_text\";\n}  // namespace millsim\n")
include(${CMAKE_CURRENT_LIST_DIR}/write_if_changed.cmake)
write_if_changed("${OUTPUT}" "${text}")
