"""Grading: course artefact checks (world and robot rubrics) and navigation challenges."""

from fleet.grading.course_robot import check_robot, grade_robot
from fleet.grading.course_world import check_world, grade_world
from fleet.grading.rubric import RubricItem, RubricReport

__all__ = ["RubricItem", "RubricReport", "check_robot", "check_world", "grade_robot", "grade_world"]
