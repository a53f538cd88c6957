# Build step: turns a URDF file into a C++ source holding its text (cmake -P script).
# Inputs: IN (urdf path), OUT (cpp path), NAME (robot name).
file(READ "${IN}" text)
string(FIND "${text}" ")rbdgrad_urdf\"" clash)
if(NOT clash EQUAL -1)
  message(FATAL_ERROR "${IN} contains the raw-string delimiter")
endif()
file(WRITE "${OUT}" "// Generated from ${IN}; do not edit.\n#include <string_view>\nnamespace rbdgrad::embedded {\nextern const std::string_view k_${NAME};\nconst std::string_view k_${NAME} = R\"rbdgrad_urdf(${text})rbdgrad_urdf\";\n}\n")
