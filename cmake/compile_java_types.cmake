# cmake -P helper: javac every generated .java file under SRC into CLASSES.
file(GLOB_RECURSE sources ${SRC}/*.java)
execute_process(COMMAND ${JAVAC} -nowarn -cp ${LCM_JAR} -d ${CLASSES} ${sources}
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "javac failed on the generated LCM types")
endif()
