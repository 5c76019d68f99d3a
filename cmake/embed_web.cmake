# Writes the web pages of `piezo view` into a C++ header as raw strings, so
# the binary serves them without files beside it.
#   cmake -DOUT=web_assets.hpp -DDIR=host/web -P embed_web.cmake
set(text "#pragma once\n// Generated from host/web by cmake/embed_web.cmake.\n#include <string_view>\n\nnamespace piezo::host::view {\n")
foreach(pair "kLiveHtml;live.html" "kRunsHtml;runs.html" "kRunHtml;run.html"
             "kLiveWindowJs;live-window.js" "kLiveWorkerJs;live-worker.js"
             "kMoveFormJs;move-form.js")
  list(GET pair 0 name)
  list(GET pair 1 file)
  file(READ "${DIR}/${file}" body)
  string(APPEND text "inline constexpr std::string_view ${name} = R\"PIEZOWEB(${body})PIEZOWEB\";\n")
endforeach()
string(APPEND text "}  // namespace piezo::host::view\n")
file(WRITE "${OUT}" "${text}")
