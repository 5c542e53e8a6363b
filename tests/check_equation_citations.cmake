cmake_minimum_required(VERSION 3.22)
# The citation check (ctest): every "Eq. N" in the code and docs cites the paper's equation
# N by its number in the paper, so a reader finds what the code implements. A citation
# must have a word of its equation's topic on its line or the lines around it (comments
# wrap); lines citing another paper (Forster et al.) are not the paper's.
# SOURCE_DIR: the checkout.

set(topic_1 "joint|graph|EFG|JFGO")
set(topic_2 "submap")
set(topic_3 "descriptor|ring|sector|polar|binning")
set(topic_4 "distance|best|XOR|similar|select")
set(topic_5 "IMU|preintegrat")
set(topic_6 "plan")  # plane, planarity, point-to-plane
set(topic_7 "odometry")
set(topic_8 "scan.match|propagation")
set(topic_9 "marginali|Schur|sliding")
set(topic_10 "marginali|Schur|sliding")
set(topic_11 "overlap")

file(GLOB_RECURSE files
     ${SOURCE_DIR}/common/*.hpp ${SOURCE_DIR}/common/*.cpp ${SOURCE_DIR}/common/*.txt
     ${SOURCE_DIR}/processes/*.cpp ${SOURCE_DIR}/tools/*.hpp ${SOURCE_DIR}/tools/*.cpp
     ${SOURCE_DIR}/bench/*.cpp ${SOURCE_DIR}/tests/*.cpp ${SOURCE_DIR}/tests/*.hpp
     ${SOURCE_DIR}/docs/*.md ${SOURCE_DIR}/README.md ${SOURCE_DIR}/config/*.yaml
     ${SOURCE_DIR}/lcmtypes/*.lcm)
set(problems "")
set(citations 0)
foreach(f ${files})
  # One list element per line: the characters CMake lists treat specially replaced first.
  file(READ ${f} content)
  foreach(special ";" "[" "]" "\\")
    string(REPLACE "${special}" "_" content "${content}")
  endforeach()
  string(REPLACE "\n" ";" lines "${content}")
  list(LENGTH lines n)
  set(index 0)
  foreach(line IN LISTS lines)
    if(line MATCHES "Eqs?\\. ?\\(?[0-9]" AND NOT line MATCHES "Forster")
      math(EXPR first "${index} - 1")
      math(EXPR last "${index} + 1")
      if(first LESS 0)
        set(first 0)
      endif()
      if(last GREATER_EQUAL n)
        math(EXPR last "${n} - 1")
      endif()
      set(context "")
      foreach(k RANGE ${first} ${last})
        list(GET lines ${k} around)
        string(APPEND context " ${around}")
      endforeach()
      string(TOLOWER "${context}" context)
      # Every number of "Eq. 4", "Eq. (4)", "Eqs. 3-4", "Eqs. (9)-(10)".
      string(REGEX MATCHALL "Eqs?\\. ?\\(?[0-9]+\\)?([-–]\\(?[0-9]+\\)?)?" cited "${line}")
      foreach(citation ${cited})
        string(REGEX MATCHALL "[0-9]+" numbers "${citation}")
        foreach(number ${numbers})
          math(EXPR citations "${citations} + 1")
          if(NOT DEFINED topic_${number})
            math(EXPR line_number "${index} + 1")
            list(APPEND problems
                 "${f}:${line_number}: Eq. ${number}: the paper has equations 1 to 11")
            continue()
          endif()
          string(TOLOWER "${topic_${number}}" topic)
          if(NOT context MATCHES "${topic}")
            math(EXPR line_number "${index} + 1")
            list(APPEND problems
                 "${f}:${line_number}: cites Eq. ${number} without its topic (${topic_${number}}): ${line}")
          endif()
        endforeach()
      endforeach()
    endif()
    math(EXPR index "${index} + 1")
  endforeach()
endforeach()
list(LENGTH problems count)
if(count GREATER 0)
  string(REPLACE ";" "\n  " text "${problems}")
  message(FATAL_ERROR "${count} citation(s) off the paper's numbering (1 joint graph, 2 "
                      "submaps, 3 descriptor, 4 best keyframe, 5 IMU, 6 point-to-plane, 7 "
                      "odometry factor, 8 scan match, 9-10 marginalization, 11 overlap):\n  ${text}")
endif()
message(STATUS "${citations} equation citations checked")
